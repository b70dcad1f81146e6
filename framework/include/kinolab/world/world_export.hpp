#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "kinolab/world/world.hpp"

namespace kinolab {

/// Writes a C-order NumPy .npy file (format 1.0). `dtype` is a NumPy descriptor such as
/// "|u1" or "<f4"; `data` holds prod(shape) items of that type.
void writeNpy(const std::string& path, const std::string& dtype, const void* data,
              std::size_t item_size, const std::vector<std::size_t>& shape);

/// An 8-bit RGB image, row 0 at the top.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;  // width * height * 3

  RgbImage(int w, int h) : width(w), height(h), pixels(static_cast<std::size_t>(w) * h * 3, 255) {}
  void set(int x, int y, const std::array<std::uint8_t, 3>& rgb) {
    const std::size_t at = (static_cast<std::size_t>(y) * width + x) * 3;
    pixels[at] = rgb[0];
    pixels[at + 1] = rgb[1];
    pixels[at + 2] = rgb[2];
  }
};

/// Writes an image as PNG (libpng); throws FileError on failure.
void writePng(const std::string& path, const RgbImage& image);

/// Top view: each (x, y) column coloured by the height of its highest occupied voxel
/// (light = low, dark = high, white = free); x to the right, y up.
RgbImage renderTopView(const World& world);
/// A horizontal slice of the ESDF at height `z` (metres): free space in a perceptual
/// colour map from near (dark) to far (bright), obstacles in red shades.
RgbImage renderEsdfSlice(const World& world, double z);

/// The most voxels a sparse world may have for exportWorld() to write its dense arrays (5
/// bytes a voxel, made voxel by voxel); a larger one gets its pictures and world.yaml only.
constexpr double kMostExportedSparseVoxels = 1 << 28;

/// Whether exportWorld() writes occupancy.npy and esdf.npy for a world of `voxels` voxels laid
/// out as `layout`; what it says instead when not ("" when it does), to be said before a
/// world is built.
std::string arraysNotExported(GridLayout layout, double voxels);

/// What `kinolab world --out DIR` writes: occupancy.npy (uint8) and esdf.npy (float32,
/// metres) when arraysNotExported() is "", world.yaml (resolution, origin, axis_order, ...,
/// and why the arrays are missing when they are), top_view.png and esdf_slice.png (at
/// `slice_height`). Returns the names of the files written.
std::vector<std::string> exportWorld(const World& world, const std::string& directory,
                                     double slice_height);

}  // namespace kinolab
