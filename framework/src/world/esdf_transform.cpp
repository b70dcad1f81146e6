// The exact cube distance transform (esdf_transform.hpp): the one-dimensional passes, the
// signed field's passes that Esdf builds from, and the whole signed transform over threads.
#include "esdf_transform.hpp"

#include <cstring>
#include <string>

#include "kinolab/core/error.hpp"

namespace kinolab::esdf_detail {
namespace {

/// The lower envelope of one pass of the cube distance transform along a line of `n` voxels,
/// in quarter voxels squared: the distance from centre q to a cube i != q voxels away along
/// the line is (2 |q - i| - 1)^2, a parabola in 2 q centred on the cube's near face, 2 i + 1
/// or 2 i - 1. Neighbouring voxels share a face, so the faces 2 k + 1 (k = -1 .. n - 1) carry
/// min(f[k], f[k + 1]); d = min(f, the lower envelope of those n + 1 parabolas at 2 q)
/// (Felzenszwalb and Huttenlocher's algorithm in integer arithmetic: no division, no
/// rounding). Entries without a site (kNoSite) are skipped, so huge sentinels never enter
/// the arithmetic. An entry at or above `limit` comes out as kNoSite (a truncated field's
/// "beyond"; see signedSquaredDistances()); the input must already hold kNoSite for those.
void lowerEnvelope(const std::int32_t* f, std::int32_t* d, int n, EnvelopeScratch& scratch,
                   std::int32_t limit) {
  std::int32_t* v = scratch.sites.data();  // the face index k + 1 (0 .. n)
  std::int64_t* g = scratch.heights.data();
  std::int64_t* zn = scratch.boundary_numerator.data();
  std::int64_t* zd = scratch.boundary_denominator.data();
  std::int32_t* height = scratch.face_heights.data();
  int k = -1;
  for (int face = 0; face <= n; ++face) {
    const std::int32_t below = face > 0 ? f[face - 1] : kNoSite;
    const std::int32_t above = face < n ? f[face] : kNoSite;
    const std::int32_t fq = std::min(below, above);
    if (fq == kNoSite) continue;
    const std::int64_t centre = 2 * static_cast<std::int64_t>(face) - 1;
    const std::int64_t gq = static_cast<std::int64_t>(fq) + centre * centre;
    std::int64_t numerator = 0;
    std::int64_t denominator = 1;
    while (k >= 0) {
      // Parabolas v[k] and this face intersect at (gq - g[k]) / (2 (centre - centre_k)).
      numerator = gq - g[k];
      denominator = 4 * static_cast<std::int64_t>(face - v[k]);
      // Keep parabola k when the intersection lies right of where k starts winning.
      if (k == 0 || numerator * zd[k] > zn[k] * denominator) break;
      --k;
    }
    ++k;
    v[k] = face;
    g[k] = gq;
    zn[k] = numerator;
    zd[k] = denominator;
    height[k] = fq;
  }
  if (k < 0) {
    std::copy(f, f + n, d);
    return;
  }
  const int last = k;
  int j = 0;
  for (int q = 0; q < n; ++q) {
    const std::int64_t x = 2 * static_cast<std::int64_t>(q);
    // Advance while the next parabola starts at or before x: zn / zd <= x.
    while (j < last && zn[j + 1] <= x * zd[j + 1]) ++j;
    const std::int64_t offset = x - (2 * static_cast<std::int64_t>(v[j]) - 1);
    const std::int64_t value = std::min<std::int64_t>(offset * offset + height[j], f[q]);
    d[q] = value >= limit ? kNoSite : static_cast<std::int32_t>(value);
  }
}

}  // namespace

/// One pass of the cube distance transform along a line of `n` voxels (lowerEnvelope()),
/// from `f` into `d`.
void transformLine(const std::int32_t* f, std::int32_t* d, int n, EnvelopeScratch& scratch) {
  // A line mostly of zeros (voxels at distance 0: in the inside transform, the free space
  // around thin obstacles) is done per non-zero entry: scanning outward while the line
  // distance alone stays below the best found, which the nearest zero bounds; with runs of
  // non-zeros at most kShortRun long that is at most kShortRun / 2 steps an entry.
  constexpr int kShortRun = 64;
  int zeros = 0;
  int run = 0;
  int longest = 0;
  for (int q = 0; q < n; ++q) {
    run = f[q] == 0 ? 0 : run + 1;
    zeros += f[q] == 0;
    longest = std::max(longest, run);
  }
  if (zeros == n) {
    std::copy(f, f + n, d);
    return;
  }
  if (zeros > 0 && longest <= kShortRun && 4 * zeros >= 3 * n) {
    for (int q = 0; q < n; ++q) {
      if (f[q] == 0) {
        d[q] = 0;
        continue;
      }
      std::int64_t best = f[q];
      for (int step = 1;; ++step) {
        const std::int64_t reach = 2 * static_cast<std::int64_t>(step) - 1;
        if (reach * reach >= best || (q - step < 0 && q + step >= n)) break;
        for (const int i : {q - step, q + step}) {
          if (i < 0 || i >= n || f[i] == kNoSite) continue;
          best = std::min(best, f[i] + reach * reach);
        }
      }
      d[q] = static_cast<std::int32_t>(best);
    }
    return;
  }
  lowerEnvelope(f, d, n, scratch, kNoSite);
}

/// Pass 1 of the cube distance transform, along z (contiguous): per voxel of the column
/// `cells` (n long), the distance to the nearest voxel of the column whose occupancy equals
/// `target`, by two sweeps, k voxels away giving (2 k - 1)^2 (0 in such a voxel; kNoSite
/// when the column has none).
void transformColumn(const std::uint8_t* cells, int n, std::uint8_t target, std::int32_t* out) {
  std::int32_t distance = kNoSite;
  for (int iz = 0; iz < n; ++iz) {
    distance = cells[iz] == target ? 0 : (distance == kNoSite ? kNoSite : distance + 1);
    out[iz] = distance;
  }
  distance = kNoSite;
  for (int iz = n - 1; iz >= 0; --iz) {
    distance = cells[iz] == target ? 0 : (distance == kNoSite ? kNoSite : distance + 1);
    const std::int32_t best = std::min(out[iz], distance);
    out[iz] = best == kNoSite ? kNoSite : (best == 0 ? 0 : (2 * best - 1) * (2 * best - 1));
  }
}

namespace {

/// The cube distance (2 k - 1)^2 to a voxel k >= 1 away along a line, kNoSite at or above
/// `limit`.
inline std::int32_t alongLine(std::int64_t k, std::int32_t limit) {
  const std::int64_t reach = 2 * k - 1;
  return reach * reach >= limit ? kNoSite : static_cast<std::int32_t>(reach * reach);
}

/// Pass 1 of the signed transform, along z (contiguous): per voxel of the column `cells` (n
/// long), the cube distance along the column to the nearest voxel of the other kind (kNoSite
/// without one, or at or above `limit`), encoded; run by run, a run's voxels being nearest to
/// one of its ends.
void signedColumn(const std::uint8_t* cells, int n, std::int32_t* out, std::int32_t limit) {
  for (int begin = 0; begin < n;) {
    const std::uint8_t kind = cells[begin];
    int end = begin + 1;
    while (end < n && cells[end] == kind) ++end;
    const bool occupied = kind != 0;
    const std::int32_t none = encodeSigned(occupied, kNoSite);
    // Steps to the other kind below (begin > 0) and above (end < n); past n, none.
    const int below = begin > 0 ? 1 : 2 * n + 1;
    const int above = end < n ? end - begin : 2 * n + 1;
    for (int i = 0; i < end - begin; ++i) {
      const int steps = std::min(below + i, above - i);
      const std::int32_t squared = steps > n ? kNoSite : alongLine(steps, limit);
      out[begin + i] = squared == kNoSite ? none : encodeSigned(occupied, squared);
    }
    begin = end;
  }
}

/// Pass 2 or 3 of the signed transform along a line of n encoded entries. A run of voxels of
/// one kind sees only its own entries and, one voxel past either end, a cube of the other
/// kind at distance 0: an entry beyond that cube is farther than the cube itself. So each run
/// is lowerEnvelope() of its own entries, lowered by its ends' cubes. `values` and `result`
/// are scratch of n entries.
void transformSignedLine(const std::int32_t* f, std::int32_t* d, int n, EnvelopeScratch& scratch,
                         std::int32_t limit, std::int32_t* values, std::int32_t* result) {
  for (int begin = 0; begin < n;) {
    const bool occupied = f[begin] < 0;
    int end = begin + 1;
    while (end < n && (f[end] < 0) == occupied) ++end;
    const int length = end - begin;
    int sites = 0;
    std::int32_t largest = 0;
    for (int i = 0; i < length; ++i) {
      values[i] = decodeSigned(f[begin + i]);
      sites += values[i] != kNoSite;
      largest = std::max(largest, values[i]);
    }
    if (sites == 0 && begin == 0 && end == n) {  // no distance within the limit
      std::copy(f, f + n, d);
      return;
    }
    // (Within a run no entry is 0: a voxel's cube is of its own kind.) Where every entry is
    // near (random voxels, a truncated field's band) each is found by a scan outwards that
    // stops where the distance along the line alone reaches the best found: a few steps an
    // entry, cheaper than the envelope's bookkeeping.
    constexpr std::int32_t kNearSquared = 16 * 16;  // 8 voxels
    if (sites == 0) {
      std::fill(result, result + length, kNoSite);
    } else if (largest <= kNearSquared) {
      for (int i = 0; i < length; ++i) {
        std::int64_t best = values[i];
        for (int step = 1;; ++step) {
          const std::int64_t reach = 2 * static_cast<std::int64_t>(step) - 1;
          if (reach * reach >= best || (i - step < 0 && i + step >= length)) break;
          if (i - step >= 0) best = std::min(best, values[i - step] + reach * reach);
          if (i + step < length) best = std::min(best, values[i + step] + reach * reach);
        }
        result[i] = best >= limit ? kNoSite : static_cast<std::int32_t>(best);
      }
    } else {
      lowerEnvelope(values, result, length, scratch, limit);
    }
    for (int i = 0; i < length; ++i) {
      std::int32_t best = result[i];
      if (begin > 0) best = std::min(best, alongLine(i + 1, limit));
      if (end < n) best = std::min(best, alongLine(length - i, limit));
      d[begin + i] = encodeSigned(occupied, best);
    }
    begin = end;
  }
}

/// Four lanes of int32 (GCC's vector extension: one SSE2 register), one line each.
using Lanes = std::int32_t __attribute__((vector_size(4 * sizeof(std::int32_t))));
constexpr std::size_t kLanes = 4;

/// True when some lane of `mask` (0 or -1 per lane) is set.
inline bool anyLane(const Lanes& mask) {
  std::uint64_t words[2];
  std::memcpy(words, &mask, sizeof(Lanes));
  return (words[0] | words[1]) != 0;
}

/// Pass 2 or 3 of the signed transform on four lines at once (`entry`, a line a lane, `length`
/// long) into `result`, when every entry is near: each line as transformSignedLine() has it,
/// found by its scan outwards for the four together, which stops where the distance along the
/// line alone reaches all four's best. The entry i steps from q offers its own value plus
/// (2 i - 1)^2 when of q's kind, else its cube, (2 i - 1)^2 alone: the cubes of the other kind
/// at a run's ends, and beyond them entries no nearer than those cubes. Exact, and so the same
/// integers as the line-by-line transform. False (`result` then partly written) when some
/// entry's scan would go past kNearSteps steps: far entries, which the envelope does in linear
/// time. Entries are capped at 2^30 in the sums (no overflow), so a best below the cap is exact
/// and one at or above it (a short line with no site, or sites that far) is left to the
/// envelope too.
bool signedNearLanes(const Lanes* entry, Lanes* result, int length, std::int32_t limit) {
  constexpr int kNearSteps = 16;
  constexpr std::int32_t kCap = std::int32_t{1} << 30;
  for (int q = 0; q < length; ++q) {
    const Lanes self = entry[q];
    const Lanes sign = self >> 31;  // -1 in an occupied voxel
    Lanes best = self ^ sign;
    for (int step = 1; q - step >= 0 || q + step < length; ++step) {
      const std::int32_t reach = (2 * step - 1) * (2 * step - 1);
      if (!anyLane(best > reach)) break;
      if (step > kNearSteps) return false;
      for (const int i : {q - step, q + step}) {
        if (i < 0 || i >= length) continue;
        const Lanes other = entry[i];
        const Lanes same = ~((other ^ self) >> 31);  // -1 where of q's kind
        Lanes value = other ^ (other >> 31);
        value = value < kCap ? value : kCap;
        const Lanes offer = (value & same) + reach;
        best = offer < best ? offer : best;
      }
    }
    if (anyLane(best >= kCap)) return false;
    const Lanes beyond = best >= limit;
    result[q] = ((best & ~beyond) | (kNoSite & beyond)) ^ sign;
  }
  return true;
}

/// The signed transform's passes over a grid of `dims` (x slowest, z fastest): pass 1 along z
/// from the occupancy, then pass 2 along y (within each x-slab, lines over iy for every iz) and
/// pass 3 along x (lines over ix for every (iy, iz)), in place, on a signed field
/// (encodeSigned(); both distances at once); with a `limit`, its entries at or above it are
/// kNoSite after every pass (a truncated field's; the default keeps every distance).
struct SignedTransform {
  explicit SignedTransform(const Eigen::Vector3i& grid_dims, std::int32_t squared_limit)
      : dims(grid_dims),
        limit(squared_limit),
        slab(static_cast<std::size_t>(dims.y()) * dims.z()),
        scratch(dims.maxCoeff()),
        in(static_cast<std::size_t>(dims.maxCoeff())),
        out(in.size()),
        run_values(in.size()),
        run_result(in.size()) {}

  /// Signed pass 2 or 3, in place, over `count` adjacent lines from `first` of `length`
  /// entries `stride` apart: four lines at a time by signedNearLanes(), or one at a time by
  /// transformSignedLine() where those have far entries.
  void signedStrided(std::int32_t* field, std::size_t first, std::size_t count, int length,
                     std::size_t stride) {
    const auto n = static_cast<std::size_t>(length);
    lanes.resize(2 * n);
    Lanes* entry = lanes.data();
    Lanes* result = lanes.data() + n;
    for (std::size_t group = 0; group < count; group += kLanes) {
      const std::size_t lines = std::min(kLanes, count - group);
      const std::size_t bytes = lines * sizeof(std::int32_t);
      std::int32_t* start = field + first + group;
      // Lanes past `lines` hold 0 (a site of their own: near) and are not written back. (A
      // whole group's copies are of a constant size: one instruction, not a call.)
      const bool whole = lines == kLanes;
      for (std::size_t q = 0; q < n; ++q) {
        if (whole) {
          std::memcpy(&entry[q], start + q * stride, sizeof(Lanes));
        } else {
          entry[q] = Lanes{};
          std::memcpy(&entry[q], start + q * stride, bytes);
        }
      }
      if (signedNearLanes(entry, result, length, limit)) {
        for (std::size_t q = 0; q < n; ++q) {
          if (whole) {
            std::memcpy(start + q * stride, &result[q], sizeof(Lanes));
          } else {
            std::memcpy(start + q * stride, &result[q], bytes);
          }
        }
        continue;
      }
      for (std::size_t line = 0; line < lines; ++line) {
        for (std::size_t q = 0; q < n; ++q) in[q] = entry[q][line];
        transformSignedLine(in.data(), out.data(), length, scratch, limit, run_values.data(),
                            run_result.data());
        for (std::size_t q = 0; q < n; ++q) start[q * stride + line] = out[q];
      }
    }
  }
  /// Signed pass 1 over the columns [begin, end) (x-y cells).
  void signedColumns(const std::uint8_t* occupancy, std::int32_t* field, std::size_t begin,
                     std::size_t end) const {
    const std::size_t nz = static_cast<std::size_t>(dims.z());
    for (std::size_t column = begin; column < end; ++column) {
      signedColumn(occupancy + column * nz, dims.z(), field + column * nz, limit);
    }
  }
  /// Signed pass 2 over the x-slabs [begin, end), in place.
  void signedAlongY(std::int32_t* field, std::size_t begin, std::size_t end) {
    end = std::min(end, static_cast<std::size_t>(dims.x()));
    for (std::size_t ix = begin; ix < end; ++ix) {
      signedStrided(field, ix * slab, static_cast<std::size_t>(dims.z()), dims.y(),
                    static_cast<std::size_t>(dims.z()));
    }
  }
  /// Signed pass 3 over the x-lines of the (y, z) cells [begin, end) (in storage order).
  void signedAlongX(std::int32_t* field, std::size_t begin, std::size_t end) {
    end = std::min(end, slab);
    if (end > begin) {
      signedStrided(field, begin, end - begin, dims.x(), slab);
    }
  }

  Eigen::Vector3i dims;
  std::int32_t limit;
  std::size_t slab;
  EnvelopeScratch scratch;
  std::vector<std::int32_t> in;
  std::vector<std::int32_t> out;
  std::vector<std::int32_t> run_values;  // transformSignedLine()'s
  std::vector<std::int32_t> run_result;
  std::vector<Lanes> lanes;  // signedStrided()'s
};

}  // namespace

void signedSquaredDistances(const VoxelGrid& grid, int threads, std::vector<std::int32_t>& field,
                            std::int32_t limit) {
  field.resize(grid.size());
  const Eigen::Vector3i& n = grid.dims();
  const auto nx = static_cast<std::size_t>(n.x());
  const auto ny = static_cast<std::size_t>(n.y());
  const auto nz = static_cast<std::size_t>(n.z());
  inParallel(nx * ny, threads, [&](std::size_t begin, std::size_t end) {
    SignedTransform(n, limit).signedColumns(grid.occupancy().data(), field.data(), begin, end);
  });
  inParallel(nx, threads, [&](std::size_t begin, std::size_t end) {
    SignedTransform(n, limit).signedAlongY(field.data(), begin, end);
  });
  // Pass 3's share: whole blocks of kBlock adjacent lines, as one thread gathers them.
  const std::size_t blocks = (ny * nz + kBlock - 1) / kBlock;
  inParallel(blocks, threads, [&](std::size_t begin, std::size_t end) {
    SignedTransform(n, limit).signedAlongX(field.data(), begin * kBlock, end * kBlock);
  });
}

void checkTransformable(const Eigen::Vector3i& n, const char* who) {
  const double squared = 4.0 * n.cast<double>().squaredNorm();
  if (squared >= static_cast<double>(kNoSite)) {
    throw InvalidArgument(std::string(who) + ": a grid of " + std::to_string(n.x()) + " x " +
                          std::to_string(n.y()) + " x " + std::to_string(n.z()) +
                          " voxels is beyond the exact transform (its diagonal must be under " +
                          "23,170 voxels); coarsen the resolution");
  }
}

}  // namespace kinolab::esdf_detail
