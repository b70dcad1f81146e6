// Private to the ESDF code: the exact cube distance transform, in integers (quarter voxels
// squared), that the dense and truncated Esdf builds (esdf.cpp, esdf_truncated.cpp) and
// IncrementalEsdf (incremental_esdf.cpp) are made of; the passes themselves are in
// esdf_transform.cpp.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>
#include <vector>

#include "kinolab/world/voxel_grid.hpp"

// Hidden: the library's own (not exported; called directly, not through the PLT).
#pragma GCC visibility push(hidden)

namespace kinolab::esdf_detail {

// Squared distances in voxel units are integers; kNoSite marks "no target in reach yet".
constexpr std::int32_t kNoSite = std::numeric_limits<std::int32_t>::max();

// Lines processed together in the strided passes: one gather reads a 64-byte cache line.
constexpr int kBlock = 16;

/// Scratch space for the one-dimensional lower-envelope transform of a line of length n.
struct EnvelopeScratch {
  explicit EnvelopeScratch(int n)
      : sites(static_cast<std::size_t>(n) + 1),
        heights(static_cast<std::size_t>(n) + 1),
        face_heights(static_cast<std::size_t>(n) + 1),
        boundary_numerator(static_cast<std::size_t>(n) + 2),
        boundary_denominator(static_cast<std::size_t>(n) + 2) {}
  std::vector<std::int32_t> sites;
  std::vector<std::int64_t> heights;       // f + centre^2
  std::vector<std::int32_t> face_heights;  // f
  // The envelope's parabola k wins from numerator / denominator onwards (denominator > 0),
  // kept as a fraction so that every comparison is exact integer arithmetic.
  std::vector<std::int64_t> boundary_numerator;
  std::vector<std::int64_t> boundary_denominator;
};

/// One pass of the cube distance transform along a line of `n` voxels, from `f` into `d`: per
/// voxel q, min over i of f[i] plus the squared distance from q's centre to the cube i voxels
/// away, (2 |q - i| - 1)^2 (0 for i = q); entries without a site are kNoSite.
void transformLine(const std::int32_t* f, std::int32_t* d, int n, EnvelopeScratch& scratch);

/// Pass 1 of the cube distance transform along a line of `n` voxels (`cells`, one byte a voxel,
/// contiguous): per voxel the distance to the nearest voxel of the line whose occupancy equals
/// `target`, k voxels away giving (2 k - 1)^2 (0 in such a voxel; kNoSite when the line has
/// none).
void transformColumn(const std::uint8_t* cells, int n, std::uint8_t target, std::int32_t* out);

// A signed field holds both transforms in one entry a voxel: a free voxel's squared distance
// (quarter voxels) to the nearest occupied cube as it is (>= 0), an occupied voxel's to the
// nearest free cube as its bitwise complement (< 0). Nothing is lost: in every pass a voxel's
// distance to cubes of its own kind is 0.
inline std::int32_t encodeSigned(bool occupied, std::int32_t squared) {
  return occupied ? ~squared : squared;
}
inline std::int32_t decodeSigned(std::int32_t entry) { return entry < 0 ? ~entry : entry; }

/// Squared Euclidean distance, in quarter voxels squared ((2 d / voxel)^2), from every free
/// voxel's centre to the nearest occupied cube and from every occupied one's to the nearest
/// free cube, as a signed field (encodeSigned()) in `field`, one entry per voxel. Exact: per
/// axis the offset to a cube k voxels away is max(|k| - 1/2, 0), a separable sum. Each pass's
/// lines are independent: `threads` threads take a share each, every line computed as by one
/// thread, so the result is the same bit for bit. With a `limit`, every distance at or above
/// it is kNoSite instead, after each pass: exact for those below, since every pass's entry is
/// at most the final one it leads to, and cheaper, since lines far from the other kind are
/// then all kNoSite.
void signedSquaredDistances(const VoxelGrid& grid, int threads, std::vector<std::int32_t>& field,
                            std::int32_t limit = kNoSite);

/// Refuses a grid whose squared distances in quarter voxels would not fit the transforms'
/// int32 (the grid's diagonal, (2 n)^2 summed over the axes, below kNoSite): about 23,000
/// voxels along the diagonal. `who` names the caller.
void checkTransformable(const Eigen::Vector3i& n, const char* who);

/// The threads a build of `grid` takes when asked for `threads` (0: one below `parallel_voxels`
/// voxels, else one per core).
inline int buildThreads(const VoxelGrid& grid, int threads, std::size_t parallel_voxels) {
  if (threads != 0) return threads;
  return grid.size() < parallel_voxels
             ? 1
             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

/// A distance, m, from its square in quarter voxels squared: kNoSite's root exceeds any real
/// distance and is capped at `cap`.
inline float cappedDistance(std::int32_t squared, float half_voxel, float cap) {
  return std::min(std::sqrt(static_cast<float>(squared)) * half_voxel, cap);
}

/// A voxel's signed distance, m, from its squared distances to the nearest occupied and the
/// nearest free cube (quarter voxels squared). Branch-free, so that loops over it vectorise.
inline float signedDistance(std::int32_t to_occupied, std::int32_t to_free, bool occupied,
                            float half_voxel, float cap) {
  const float outside = cappedDistance(to_occupied, half_voxel, cap);
  const float inside = cappedDistance(to_free, half_voxel, cap);
  return occupied ? -inside : outside;
}

/// Calls work(begin, end) on `parts` contiguous ranges splitting [0, count), each on a thread
/// of its own (the caller's thread takes the first); rethrows the first exception.
template <typename Work>
void inParallel(std::size_t count, int parts, const Work& work) {
  const std::size_t n = std::min<std::size_t>(static_cast<std::size_t>(std::max(parts, 1)), count);
  if (n <= 1) {
    work(std::size_t{0}, count);
    return;
  }
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto part = [&](std::size_t k) {
    try {
      work(k * count / n, (k + 1) * count / n);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(n - 1);
  for (std::size_t k = 1; k < n; ++k) threads.emplace_back(part, k);
  part(0);
  for (std::thread& thread : threads) thread.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace kinolab::esdf_detail

#pragma GCC visibility pop
