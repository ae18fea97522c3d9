// OctoMap .bt reader (maptune walks the bytes before OctoMap's recursive reader sees them).
#include <exception>
#include <string>

#include "dataset/geometry.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        (void)maptune::dataset::octree_from_bt(std::string(reinterpret_cast<const char*>(data), size), "fuzz.bt");
    } catch (const std::exception&) {
    }
    return 0;
}
