// Point cloud readers (PCD ascii/binary, PLY ascii/binary): the first byte picks the format,
// the rest is the file. Any exception is a clear error; a crash, a leak or undefined behaviour
// is a finding.
#include <exception>

#include "dataset/io.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    const char* name = (data[0] & 1) ? "in.ply" : "in.pcd";
    const auto path = maptune::fuzz::write_input(name, data + 1, size - 1);
    try {
        maptune::dataset::ReadOptions o;
        o.drop_nan = (data[0] & 2) != 0;
        (void)maptune::dataset::read_cloud(path, o);
    } catch (const std::exception&) {
    }
    return 0;
}
