// TUM trajectory reader (timestamp tx ty tz qx qy qz qw per line).
#include <exception>

#include "dataset/io.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = maptune::fuzz::write_input("in.tum", data, size);
    try {
        (void)maptune::dataset::read_tum(path);
    } catch (const std::exception&) {
    }
    return 0;
}
