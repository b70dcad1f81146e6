#include "kinolab/world/world_export.hpp"

#include <png.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "kinolab/core/error.hpp"
#include "kinolab/core/files.hpp"
#include "kinolab/core/hash.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

Rgb lerp(const Rgb& a, const Rgb& b, double t) {
  Rgb out;
  for (int i = 0; i < 3; ++i)
    out[i] = static_cast<std::uint8_t>(std::lround(a[i] + (b[i] - a[i]) * t));
  return out;
}

/// Piecewise-linear colour map through evenly spaced anchors; t in [0, 1].
template <std::size_t N>
Rgb colourMap(const std::array<Rgb, N>& anchors, double t) {
  t = std::clamp(t, 0.0, 1.0) * (N - 1);
  const auto i = std::min(static_cast<std::size_t>(t), N - 2);
  return lerp(anchors[i], anchors[i + 1], t - i);
}

// Viridis, sampled at nine points.
constexpr std::array<Rgb, 9> kViridis = {{{68, 1, 84},
                                          {71, 44, 122},
                                          {59, 81, 139},
                                          {44, 113, 142},
                                          {33, 144, 141},
                                          {39, 173, 129},
                                          {92, 200, 99},
                                          {170, 220, 50},
                                          {253, 231, 37}}};
// Light sand to dark green-brown for heights.
constexpr std::array<Rgb, 4> kHeight = {
    {{230, 220, 190}, {150, 180, 110}, {60, 110, 60}, {30, 45, 30}}};

/// Upscale factor so that small grids still make a readable picture.
int pictureScale(const Eigen::Vector3i& dims) {
  const int smaller = std::max(1, std::min(dims.x(), dims.y()));
  return std::clamp(400 / smaller, 1, 16);
}

/// The highest occupied voxel of the column (ix, iy), -1 when there is none; a sparse grid
/// is read a brick's row (8 voxels) at a time, so a 1 km city's picture is seconds.
int columnTop(const VoxelGrid& grid, int ix, int iy) {
  const int height = grid.dims().z();
  if (grid.layout() == GridLayout::kBricked) {
    for (int bz = (height - 1) / VoxelGrid::kBrick; bz >= 0; --bz) {
      unsigned row = grid.brickRow(ix, iy, bz);
      const int past_top = (bz + 1) * VoxelGrid::kBrick - height;  // a full brick's extra bits
      if (past_top > 0) row &= 0xFFu >> past_top;
      if (row != 0) return bz * VoxelGrid::kBrick + std::bit_width(row) - 1;
    }
    return -1;
  }
  for (int iz = height - 1; iz >= 0; --iz) {
    if (grid.occupied(VoxelIndex(ix, iy, iz))) return iz;
  }
  return -1;
}

}  // namespace

void writeNpy(const std::string& path, const std::string& dtype, const void* data,
              std::size_t item_size, const std::vector<std::size_t>& shape) {
  std::string shape_text = "(";
  std::size_t count = 1;
  for (std::size_t i = 0; i < shape.size(); ++i) {
    shape_text += std::to_string(shape[i]) + (shape.size() == 1 || i + 1 < shape.size() ? "," : "");
    if (i + 1 < shape.size()) shape_text += " ";
    count *= shape[i];
  }
  shape_text += ")";
  std::string header =
      "{'descr': '" + dtype + "', 'fortran_order': False, 'shape': " + shape_text + ", }";
  // Magic (6) + version (2) + length (2) + header, padded with spaces to a multiple of 64
  // and ended by a newline, as the format asks.
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  OutputFile out(path);
  const char preamble[8] = {'\x93', 'N', 'U', 'M', 'P', 'Y', 1, 0};
  out.write(preamble, sizeof(preamble));
  const auto length = static_cast<std::uint16_t>(header.size());
  const char length_bytes[2] = {static_cast<char>(length & 0xff), static_cast<char>(length >> 8)};
  out.write(length_bytes, 2);
  out.write(header.data(), header.size());
  out.write(data, count * item_size);
  out.close();
}

void writePng(const std::string& path, const RgbImage& image) {
  OutputFile out(path);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw FileError(path + ": PNG encoding failed");
  }
  png_init_io(png, out.stream());
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width),
               static_cast<png_uint_32>(image.height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) {
    png_write_row(png, image.pixels.data() + static_cast<std::size_t>(y) * image.width * 3);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  out.close();
}

RgbImage renderTopView(const World& world) {
  const VoxelGrid& grid = world.grid();
  const Eigen::Vector3i& dims = grid.dims();
  const int scale = pictureScale(dims);
  RgbImage image(dims.x() * scale, dims.y() * scale);
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      const int top = columnTop(grid, ix, iy);
      const Rgb colour = top < 0 ? Rgb{255, 255, 255}
                                 : colourMap(kHeight, dims.z() > 1 ? top / (dims.z() - 1.0) : 1.0);
      for (int dx = 0; dx < scale; ++dx) {
        for (int dy = 0; dy < scale; ++dy) {
          image.set(ix * scale + dx, (dims.y() - 1 - iy) * scale + dy, colour);
        }
      }
    }
  }
  return image;
}

RgbImage renderEsdfSlice(const World& world, double z) {
  const VoxelGrid& grid = world.grid();
  const Eigen::Vector3i& dims = grid.dims();
  const int scale = pictureScale(dims);
  const double resolution = grid.resolution();
  // Colour scale: clearances beyond 3 m (or a quarter of the map) look the same.
  const double far = std::min(3.0, 0.25 * (dims.head<2>().cast<double>() * resolution).maxCoeff());
  RgbImage image(dims.x() * scale, dims.y() * scale);
  // A column of the picture at a time, its distances in one batched query.
  std::vector<Eigen::Vector3d> points(static_cast<std::size_t>(image.height));
  std::vector<double> distances(points.size());
  for (int px = 0; px < image.width; ++px) {
    for (int py = 0; py < image.height; ++py) {
      points[static_cast<std::size_t>(py)] = {
          grid.origin().x() + (px + 0.5) * resolution / scale,
          grid.origin().y() + (image.height - py - 0.5) * resolution / scale, z};
    }
    world.esdf().distances(points, distances);
    for (int py = 0; py < image.height; ++py) {
      const double d = distances[static_cast<std::size_t>(py)];
      const Rgb colour = d < 0.0 ? lerp(Rgb{240, 90, 80}, Rgb{120, 0, 0}, std::min(1.0, -d / far))
                                 : colourMap(kViridis, d / far);
      image.set(px, py, colour);
    }
  }
  return image;
}

namespace {

/// occupancy.npy and esdf.npy of `world` in `dir` (a sparse world's made voxel by voxel).
void writeArrays(const World& world, const std::filesystem::path& dir,
                 const std::vector<std::size_t>& shape) {
  const VoxelGrid& grid = world.grid();
  if (grid.layout() == GridLayout::kBricked) {
    std::vector<std::uint8_t> occupancy(grid.size());
    std::vector<float> values(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
      occupancy[i] = grid.occupied(i) ? 1 : 0;
      values[i] = world.esdf().voxelDistance(i);
    }
    writeNpy((dir / "occupancy.npy").string(), "|u1", occupancy.data(), 1, shape);
    writeNpy((dir / "esdf.npy").string(), "<f4", values.data(), sizeof(float), shape);
  } else {
    writeNpy((dir / "occupancy.npy").string(), "|u1", grid.occupancy().data(), 1, shape);
    writeNpy((dir / "esdf.npy").string(), "<f4", world.esdf().values().data(), sizeof(float),
             shape);
  }
}

}  // namespace

std::string arraysNotExported(GridLayout layout, double voxels) {
  if (layout != GridLayout::kBricked || voxels <= kMostExportedSparseVoxels) return "";
  return "a sparse world of " + formatNumber(voxels) +
         " voxels is too large for dense arrays (at most " +
         formatNumber(kMostExportedSparseVoxels) +
         "): occupancy.npy and esdf.npy are not written, the pictures and world.yaml are";
}

std::vector<std::string> exportWorld(const World& world, const std::string& directory,
                                     double slice_height) {
  const VoxelGrid& grid = world.grid();
  const bool sparse = grid.layout() == GridLayout::kBricked;
  const std::string no_arrays = arraysNotExported(grid.layout(), static_cast<double>(grid.size()));
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) throw FileError(directory + ": cannot create directory: " + error.message());
  const std::filesystem::path dir(directory);
  const std::vector<std::size_t> shape = {static_cast<std::size_t>(grid.dims().x()),
                                          static_cast<std::size_t>(grid.dims().y()),
                                          static_cast<std::size_t>(grid.dims().z())};
  std::vector<std::string> written;
  if (no_arrays.empty()) {
    whileDoing("exporting the world '" + world.name() + "' as arrays",
               [&] { writeArrays(world, dir, shape); });
    written = {"occupancy.npy", "esdf.npy"};
  }

  YAML::Emitter yaml;
  yaml << YAML::BeginMap;
  yaml << YAML::Key << "name" << YAML::Value << world.name();
  yaml << YAML::Key << "spec_hash" << YAML::Value << toHex(world.specHash());
  yaml << YAML::Key << "resolution" << YAML::Value << grid.resolution();
  yaml << YAML::Key << "origin" << YAML::Value << YAML::Flow << YAML::BeginSeq << grid.origin().x()
       << grid.origin().y() << grid.origin().z() << YAML::EndSeq;
  yaml << YAML::Key << "axis_order" << YAML::Value << "xyz";
  yaml << YAML::Key << "shape" << YAML::Value << YAML::Flow << YAML::BeginSeq << shape[0]
       << shape[1] << shape[2] << YAML::EndSeq;
  yaml << YAML::Key << "occupied_voxels" << YAML::Value << grid.occupiedCount();
  yaml << YAML::Key << "esdf" << YAML::Value
       << "metres, one value per voxel: at a free voxel the distance from its centre to the "
          "nearest occupied voxel cube (half a voxel next to one), at an occupied voxel minus "
          "the distance from its centre to the nearest free cube";
  if (sparse) {
    yaml << YAML::Key << "truncation" << YAML::Value << world.esdf().truncation();
  }
  yaml << YAML::Key << "slice_height" << YAML::Value << slice_height;
  if (!no_arrays.empty()) yaml << YAML::Key << "arrays" << YAML::Value << no_arrays;
  yaml << YAML::EndMap;
  writeFileAtomically((dir / "world.yaml").string(), std::string(yaml.c_str()) + '\n');

  writePng((dir / "top_view.png").string(), renderTopView(world));
  writePng((dir / "esdf_slice.png").string(), renderEsdfSlice(world, slice_height));
  written.insert(written.end(), {"world.yaml", "top_view.png", "esdf_slice.png"});
  return written;
}

}  // namespace kinolab
