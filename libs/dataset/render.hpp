#pragma once
// PNG renderings that show a dataset looks right (docs/*.png).

#include <cstdint>
#include <filesystem>
#include <vector>

#include "dataset/dataset.hpp"

namespace maptune::dataset {

struct Image {
    int width = 0, height = 0;
    std::vector<std::uint8_t> rgb;  // row-major, 3 bytes per pixel
    Image(int w, int h, std::uint8_t grey = 255) : width(w), height(h), rgb(std::size_t(w) * h * 3, grey) {}
    void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
};
void write_png(const std::filesystem::path& file, const Image& img);

// Top-down view of a run: its submaps' clouds in the gt world frame, gt (green) and
// odometry (red) trajectories, and each submap's outline (blue) with its index.
Image render_run_topdown(const Dataset& ds, int run, int width_px);
// Oblique view of one submap's cloud (true colour) with its obstacle points (red).
Image render_submap(const Submap& submap, int width_px, int height_px);

}  // namespace maptune::dataset
