#include "kinolab/world/esdf.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "kinolab/core/error.hpp"
#include "kinolab/core/huge_pages.hpp"

namespace kinolab {
namespace {

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

/// Runs a 1-D transform over every line along one strided axis, from `from` into `to` (the
/// same array or another of the same layout). Lines start at `first + inner` for inner in
/// [0, inner_count), with `length` elements `stride` apart; `inner_count` consecutive lines are
/// contiguous in memory, so they are gathered kBlock at a time into contiguous rows of `in`,
/// transformed by transform(row of in, row of out) and scattered back.
template <typename T, typename Transform>
void transformStrided(const T* from, std::int32_t* to, std::size_t first, std::size_t inner_count,
                      int length, std::size_t stride, std::vector<T>& in,
                      std::vector<std::int32_t>& out, const Transform& transform) {
  const std::size_t n = static_cast<std::size_t>(length);
  for (std::size_t inner = 0; inner < inner_count; inner += kBlock) {
    const std::size_t lines = std::min<std::size_t>(kBlock, inner_count - inner);
    for (std::size_t q = 0; q < n; ++q) {
      const T* row = from + first + inner + q * stride;
      for (std::size_t line = 0; line < lines; ++line) in[line * n + q] = row[line];
    }
    for (std::size_t line = 0; line < lines; ++line) {
      transform(in.data() + line * n, out.data() + line * n);
    }
    for (std::size_t q = 0; q < n; ++q) {
      std::int32_t* row = to + first + inner + q * stride;
      for (std::size_t line = 0; line < lines; ++line) row[line] = out[line * n + q];
    }
  }
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

// A signed field holds both transforms in one entry a voxel: a free voxel's squared distance
// (quarter voxels) to the nearest occupied cube as it is (>= 0), an occupied voxel's to the
// nearest free cube as its bitwise complement (< 0). Nothing is lost: in every pass a voxel's
// distance to cubes of its own kind is 0.
inline std::int32_t encodeSigned(bool occupied, std::int32_t squared) {
  return occupied ? ~squared : squared;
}
inline std::int32_t decodeSigned(std::int32_t entry) { return entry < 0 ? ~entry : entry; }

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

/// An entry of a pass's result that an update changed, as the next pass's lines see it: the
/// line it lies on, its position along that line and its value before.
struct LineChange {
  std::uint32_t line;
  int position;
  std::int32_t old;
};

/// `changes` grouped by line, in line order (a counting sort: an update's changes are many
/// and its lines few), into `sorted`; `starts[l]` .. `starts[l + 1]` are line l's.
void byLine(const std::vector<LineChange>& changes, std::size_t lines,
            std::vector<LineChange>& sorted, std::vector<std::uint32_t>& starts) {
  starts.assign(lines + 1, 0);
  for (const LineChange& c : changes) ++starts[c.line + 1];
  for (std::size_t l = 0; l < lines; ++l) starts[l + 1] += starts[l];
  sorted.resize(changes.size());
  std::vector<std::uint32_t> next(starts.begin(), starts.end() - 1);
  for (const LineChange& c : changes) sorted[next[c.line]++] = c;
}

/// The three passes over a grid of `dims` (x slowest, z fastest): pass 1 along z from the
/// occupancy, then pass 2 along y (within each x-slab, lines over iy for every iz) and pass 3
/// along x (lines over ix for every (iy, iz)), in place (Esdf); IncrementalEsdf's order, x, y
/// and z, each pass into the next one's array (rows(), alongY(), alongZ()), and one line at
/// a time (line(), update()). Esdf's passes are on a signed field (encodeSigned(); both
/// distances at once); with a `limit`, its entries at or above it are kNoSite after every pass
/// (a truncated field's; the default keeps every distance).
struct CubeTransform {
  explicit CubeTransform(const Eigen::Vector3i& grid_dims, std::int32_t squared_limit = kNoSite)
      : dims(grid_dims),
        limit(squared_limit),
        slab(static_cast<std::size_t>(dims.y()) * dims.z()),
        scratch(dims.maxCoeff()),
        in(static_cast<std::size_t>(kBlock) * dims.maxCoeff()),
        out(in.size()),
        suspects(static_cast<std::size_t>(dims.maxCoeff())),
        run_values(suspects.size()),
        run_result(suspects.size()) {}

  /// transformLine() over lines of `length` with this transform's scratch space.
  auto envelope(int length) {
    return [this, length](const std::int32_t* f, std::int32_t* d) {
      transformLine(f, d, length, scratch);
    };
  }
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
  /// Pass 2 over the x-slabs [begin, end), from `from` into `to` (the same or another).
  void alongY(const std::int32_t* from, std::int32_t* to, std::size_t begin = 0,
              std::size_t end = kAll) {
    end = std::min(end, static_cast<std::size_t>(dims.x()));
    for (std::size_t ix = begin; ix < end; ++ix) {
      transformStrided(from, to, ix * slab, static_cast<std::size_t>(dims.z()), dims.y(),
                       static_cast<std::size_t>(dims.z()), in, out, envelope(dims.y()));
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
  /// Pass 1 along x instead (IncrementalEsdf's order): every x-line of `occupancy` into
  /// `squared`, as transformColumn() has it, by two sweeps over the x-slabs (every line at
  /// once, contiguous).
  void rows(const std::uint8_t* occupancy, std::uint8_t target, std::int32_t* squared) {
    const auto nx = static_cast<std::size_t>(dims.x());
    // Forward: the steps back to the nearest target voxel.
    for (std::size_t x = 0; x < nx; ++x) {
      const std::uint8_t* cells = occupancy + x * slab;
      std::int32_t* steps = squared + x * slab;
      const std::int32_t* behind = x > 0 ? steps - slab : nullptr;
      for (std::size_t i = 0; i < slab; ++i) {
        const std::int32_t last = behind != nullptr ? behind[i] : kNoSite;
        steps[i] = cells[i] == target ? 0 : (last == kNoSite ? kNoSite : last + 1);
      }
    }
    // Backward: the steps ahead, the nearer of the two, squared as a cube distance.
    std::vector<std::int32_t> ahead(slab, kNoSite);
    for (std::size_t x = nx; x-- > 0;) {
      const std::uint8_t* cells = occupancy + x * slab;
      std::int32_t* steps = squared + x * slab;
      for (std::size_t i = 0; i < slab; ++i) {
        const std::int32_t next = ahead[i];
        ahead[i] = cells[i] == target ? 0 : (next == kNoSite ? kNoSite : next + 1);
        const std::int32_t best = std::min(steps[i], ahead[i]);
        steps[i] = best == kNoSite ? kNoSite : (best == 0 ? 0 : (2 * best - 1) * (2 * best - 1));
      }
    }
  }
  /// Pass 3 along z instead (IncrementalEsdf's order): every column of `from` into `to`
  /// (another array).
  void alongZ(const std::int32_t* from, std::int32_t* to) {
    const auto nz = static_cast<std::size_t>(dims.z());
    const std::size_t count = static_cast<std::size_t>(dims.x()) * dims.y();
    for (std::size_t column = 0; column < count; ++column) {
      transformLine(from + column * nz, to + column * nz, dims.z(), scratch);
    }
  }
  static constexpr std::size_t kAll = std::numeric_limits<std::size_t>::max();
  /// One line of pass 2 or 3 alone: `length` entries of `from`, `stride` apart from `first`,
  /// transformed into `to` at the same places; calls changed(q, old) for every entry of `to`
  /// that this alters (q along the line, old its value before).
  template <typename Changed>
  void line(const std::int32_t* from, std::int32_t* to, std::size_t first, int length,
            std::size_t stride, Changed&& changed) {
    for (int q = 0; q < length; ++q) in[q] = from[first + q * stride];
    transformLine(in.data(), out.data(), length, scratch);
    for (int q = 0; q < length; ++q) {
      const std::size_t index = first + q * stride;
      if (to[index] != out[q]) {
        changed(q, to[index]);
        to[index] = out[q];
      }
    }
  }
  /// The same line after `from` changed at [begin, end) (positions along it, with their old
  /// values; `from` holds the new ones), `to` holding the transform of the old `from`. An
  /// entry of `to` is min over i of from[i] + g(q - i): where its minimum came from no entry
  /// that grew, the new one is the old one lowered by the entries that shrank; where it did
  /// (a suspect), it is found anew by a scan outwards from q that stops where the distance
  /// along the line alone reaches the best found. With many suspects the whole line is
  /// transformed anew instead (then true). Calls changed(q, old) as line() does.
  template <typename Changed>
  bool update(const std::int32_t* from, std::int32_t* to, std::size_t first, int length,
              std::size_t stride, const LineChange* begin, const LineChange* end,
              Changed&& changed) {
    // The cube distance along the line: (2 |k| - 1)^2 for k != 0 voxels apart, 0 for k = 0.
    const auto along = [](int k) -> std::int64_t {
      const std::int64_t reach = 2 * static_cast<std::int64_t>(std::abs(k)) - 1;
      return k == 0 ? 0 : reach * reach;
    };
    // A scan costs about as much as a few entries of the transform, and so does lowering the
    // line by one shrunk input (measured on a flight's window: most changed lines have at
    // most 8 suspects); a line with many of either is transformed anew (a wall appeared).
    const int most = length / 4;
    if (end - begin > most) {
      line(from, to, first, length, stride, changed);
      return true;
    }
    std::int32_t* old = in.data();
    std::int32_t* lowered = out.data();
    std::uint8_t* suspect = suspects.data();
    for (int q = 0; q < length; ++q) {
      old[q] = lowered[q] = to[first + q * stride];
      suspect[q] = 0;
    }
    int count = 0;
    for (const LineChange* c = begin; c != end; ++c) {
      if (from[first + c->position * stride] <= c->old) continue;
      const std::int64_t was = c->old;
      for (int q = 0; q < length; ++q) {
        if (suspect[q] == 0 && was + along(q - c->position) == old[q]) {
          suspect[q] = 1;
          if (++count > most) {
            line(from, to, first, length, stride, changed);
            return true;
          }
        }
      }
    }
    for (const LineChange* c = begin; c != end; ++c) {
      const std::int64_t now = from[first + c->position * stride];
      if (now >= c->old) continue;
      for (int q = 0; q < length; ++q) {
        const std::int64_t value = now + along(q - c->position);
        if (value < lowered[q]) lowered[q] = static_cast<std::int32_t>(value);
      }
    }
    for (int q = 0; count > 0 && q < length; ++q) {
      if (suspect[q] == 0) continue;
      --count;
      std::int64_t best = from[first + q * stride];
      for (int step = 1; q - step >= 0 || q + step < length; ++step) {
        const std::int64_t reach = along(step);
        if (reach >= best) break;
        for (const int i : {q - step, q + step}) {
          if (i < 0 || i >= length) continue;
          best = std::min(best, from[first + i * stride] + reach);  // (int64: kNoSite + reach)
        }
      }
      lowered[q] = static_cast<std::int32_t>(best);
    }
    for (int q = 0; q < length; ++q) {
      if (lowered[q] != old[q]) {
        changed(q, old[q]);
        to[first + q * stride] = lowered[q];
      }
    }
    return false;
  }

  Eigen::Vector3i dims;
  std::int32_t limit;
  std::size_t slab;
  EnvelopeScratch scratch;
  std::vector<std::int32_t> in;
  std::vector<std::int32_t> out;
  std::vector<std::uint8_t> suspects;    // update()'s
  std::vector<std::int32_t> run_values;  // transformSignedLine()'s
  std::vector<std::int32_t> run_result;
  std::vector<Lanes> lanes;  // signedStrided()'s
};

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
                            std::int32_t limit = kNoSite) {
  field.resize(grid.size());
  const Eigen::Vector3i& n = grid.dims();
  const auto nx = static_cast<std::size_t>(n.x());
  const auto ny = static_cast<std::size_t>(n.y());
  const auto nz = static_cast<std::size_t>(n.z());
  inParallel(nx * ny, threads, [&](std::size_t begin, std::size_t end) {
    CubeTransform(n, limit).signedColumns(grid.occupancy().data(), field.data(), begin, end);
  });
  inParallel(nx, threads, [&](std::size_t begin, std::size_t end) {
    CubeTransform(n, limit).signedAlongY(field.data(), begin, end);
  });
  // Pass 3's share: whole blocks of kBlock adjacent lines, as one thread gathers them.
  const std::size_t blocks = (ny * nz + kBlock - 1) / kBlock;
  inParallel(blocks, threads, [&](std::size_t begin, std::size_t end) {
    CubeTransform(n, limit).signedAlongX(field.data(), begin * kBlock, end * kBlock);
  });
}

/// Refuses a grid whose squared distances in quarter voxels would not fit the transforms'
/// int32 (the grid's diagonal, (2 n)^2 summed over the axes, below kNoSite): about 23,000
/// voxels along the diagonal. `who` names the caller.
void checkTransformable(const Eigen::Vector3i& n, const char* who) {
  const double squared = 4.0 * n.cast<double>().squaredNorm();
  if (squared >= static_cast<double>(kNoSite)) {
    throw InvalidArgument(std::string(who) + ": a grid of " + std::to_string(n.x()) + " x " +
                          std::to_string(n.y()) + " x " + std::to_string(n.z()) +
                          " voxels is beyond the exact transform (its diagonal must be under " +
                          "23,170 voxels); coarsen the resolution");
  }
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

/// The search of Esdf::exactDistance() (voxel units): the occupied voxel (negative value)
/// whose cube is nearest to the point, among the voxels [from, to] within sqrt(best2) of it,
/// skipping the ball of radius sqrt(inner2) about the point, known free. From the point's
/// voxel outwards along x, then y, then z, both ways: the gaps grow, so each way stops at the
/// first voxel beyond the best (and along z at the first occupied one), and everything stops
/// at a cube nearer than sqrt(enough2).
/// A dense field's z-rows (x and y strides; z is contiguous).
struct DenseRows {
  const float* values;
  std::int64_t strides[2];
  const float* operator()(std::int64_t x, std::int64_t y) const {
    return values + x * strides[0] + y * strides[1];
  }
};

/// A truncated field's z-rows, through its brick table.
struct BrickRows {
  struct Row {
    const std::int16_t* const* bricks;  // the column of bricks holding the row
    std::size_t inner;                  // the row within a brick
    const float* values;                // of the codes
    float operator[](std::int64_t z) const {
      return values[static_cast<std::uint16_t>(
          bricks[static_cast<std::size_t>(z) >> 3][inner | (static_cast<std::size_t>(z) & 7)])];
    }
  };
  const std::int16_t* const* table;
  std::size_t strides[2];  // bricks per x and per y step
  const float* values;
  Row operator()(std::int64_t x, std::int64_t y) const {
    const auto ux = static_cast<std::size_t>(x);
    const auto uy = static_cast<std::size_t>(y);
    return {table + (ux >> 3) * strides[0] + (uy >> 3) * strides[1],
            ((ux & 7) << 6) | ((uy & 7) << 3), values};
  }
};

/// The search of exactDistance(), over a field's z-rows (`Rows`: DenseRows or BrickRows).
template <typename Rows>
struct NearestCubeSearch {
  Rows rows;
  double scaled[3] = {0, 0, 0};      // the point
  std::int64_t cell[3] = {0, 0, 0};  // its voxel (clamped into the grid)
  std::int64_t from[3] = {0, 0, 0};
  std::int64_t to[3] = {0, 0, 0};
  double inner2 = 0.0;
  double best2 = 0.0;
  double enough2 = -1.0;
  bool found = false;

  /// Distance along an axis from the point to the slab of voxel i: [i, i + 1].
  double gap(int axis, std::int64_t i) const {
    const double low = static_cast<double>(i);
    const double x = scaled[axis];
    return x < low ? low - x : (x > low + 1.0 ? x - low - 1.0 : 0.0);
  }
  /// Beyond the best so far (a cube exactly at the first upper bound still counts).
  bool beyond(double d2) const { return found ? d2 >= best2 : d2 > best2; }

  /// One way along z: false at the first voxel beyond the best or the first occupied one.
  template <typename Row>
  bool visit(const Row& row, double gxy2, std::int64_t z) {
    const double gz = gap(2, z);
    const double d2 = gxy2 + gz * gz;
    if (beyond(d2)) return false;
    if (!(row[z] < 0.0f)) return true;
    best2 = d2;
    found = true;
    return false;
  }

  /// The column (x, y) from the first voxel outside the free ball, both ways: below, z <= cell
  /// with a gap scaled - z - 1 of at least free_z; above, z > cell with a gap z - scaled of at
  /// least free_z. False when the search is done.
  bool column(std::int64_t x, std::int64_t y, double gxy2) {
    const auto row = rows(x, y);
    const double free_z = gxy2 < inner2 ? std::sqrt(inner2 - gxy2) : 0.0;
    const std::int64_t below =
        free_z > 0.0
            ? std::min(cell[2], static_cast<std::int64_t>(std::floor(scaled[2] - 1.0 - free_z)))
            : cell[2];
    for (std::int64_t z = below; z >= from[2] && visit(row, gxy2, z); --z) {
    }
    const std::int64_t above =
        std::max(cell[2] + 1, static_cast<std::int64_t>(std::ceil(scaled[2] + free_z)));
    for (std::int64_t z = above; z <= to[2] && visit(row, gxy2, z); ++z) {
    }
    return !(found && best2 < enough2);
  }

  /// Along `axis` from the point's voxel, both ways; `step(i)` is 1 to go on, 0 when this way
  /// is done, -1 when the search is. False when the search is done.
  template <typename Step>
  bool sweep(int axis, const Step& step) {
    for (std::int64_t i = cell[axis]; i >= from[axis]; --i) {
      const int next = step(i);
      if (next < 0) return false;
      if (next == 0) break;
    }
    for (std::int64_t i = cell[axis] + 1; i <= to[axis]; ++i) {
      const int next = step(i);
      if (next <= 0) return next == 0;
    }
    return true;
  }

  void run() {
    sweep(0, [&](std::int64_t x) {
      const double gx2 = gap(0, x) * gap(0, x);
      if (beyond(gx2)) return 0;
      return sweep(1,
                   [&](std::int64_t y) {
                     const double gxy2 = gx2 + gap(1, y) * gap(1, y);
                     if (beyond(gxy2)) return 0;
                     return column(x, y, gxy2) ? 1 : -1;
                   })
                 ? 1
                 : -1;
    });
  }
};

}  // namespace

void Esdf::setGeometry(const VoxelGrid& grid) {
  dims_ = grid.dims();
  resolution_ = grid.resolution();
  inverse_resolution_ = 1.0 / resolution_;
  origin_ = grid.origin();
  max_distance_ = (dims_.cast<double>() * resolution_).norm();
  strides_[0] = static_cast<std::size_t>(dims_.y()) * dims_.z();
  strides_[1] = static_cast<std::size_t>(dims_.z());
  strides_[2] = 1;
  for (int axis = 0; axis < 3; ++axis) {
    upper_[axis] = dims_[axis] - 1;
    lower_corner_[axis] = std::max(0, dims_[axis] - 2);
    shift_[axis] = origin_[axis] * inverse_resolution_ + 0.5;
    neighbour_step_[axis] = dims_[axis] > 1 ? strides_[axis] : 0;
    unit_step_[axis] = dims_[axis] > 1 ? 1 : 0;
    gradient_scale_[axis] = dims_[axis] > 1 ? inverse_resolution_ : 0.0;
  }
}

Esdf::Esdf(const VoxelGrid& grid, int threads) {
  if (grid.size() == 0) throw InvalidArgument("Esdf: empty grid");
  if (threads < 0) throw InvalidArgument("Esdf: threads must be >= 0");
  checkTransformable(grid.dims(), "Esdf");
  if (threads == 0) {
    threads = grid.size() < kParallelVoxels
                  ? 1
                  : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }
  setGeometry(grid);
  values_ = vectorOnHugePages<float>(grid.size());
  const auto cap = static_cast<float>(max_distance_);
  const auto half_voxel = static_cast<float>(0.5 * resolution_);  // the fields are in half voxels
  // Both distances in one signed field (the build holds 9 bytes a voxel: the occupancy, the
  // values and the field): a free voxel's value is its distance to the occupied cubes, an
  // occupied one's minus its distance to the free cubes.
  std::vector<std::int32_t> field;
  signedSquaredDistances(grid, threads, field);
  inParallel(grid.size(), threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float distance = cappedDistance(decodeSigned(field[i]), half_voxel, cap);
      values_[i] = field[i] < 0 ? -distance : distance;
    }
  });
}

Esdf::Esdf(const VoxelGrid& grid, std::vector<float> values) : values_(std::move(values)) {
  if (values_.size() != grid.size()) {
    throw InvalidArgument("Esdf: " + std::to_string(values_.size()) + " values for " +
                          std::to_string(grid.size()) + " voxels");
  }
  setGeometry(grid);
}

struct Esdf::Bricks {
  std::vector<const std::int16_t*> table;
  std::vector<std::unique_ptr<std::int16_t[]>> chunks;  // the allocated bricks, one per tile
  std::size_t allocated = 0;
  std::int16_t far[kBrickVoxels];
  std::int16_t deep[kBrickVoxels];
  std::vector<float> values;  // of each code, as 16 bits
};

namespace {

// A voxel's code in a truncated field: +-(squared distance in half voxels) within T, else
// +-kBeyond (T itself); 90 voxels of truncation square to 32,400 half voxels.
constexpr std::int16_t kBeyond = 32767;
constexpr double kMostTruncationVoxels = 90.0;

}  // namespace

const std::vector<float>& Esdf::values() const {
  if (brick_table_) {
    throw InvalidArgument(
        "Esdf::values: a truncated (sparse) field has no dense array; query it by voxel");
  }
  return values_;
}

std::size_t Esdf::allocatedBricks() const { return bricks_ ? bricks_->allocated : 0; }

std::size_t Esdf::memoryBytes() const {
  if (!bricks_) return values_.capacity() * sizeof(float);
  return bricks_->table.capacity() * sizeof(const std::int16_t*) +
         bricks_->allocated * kBrickVoxels * sizeof(std::int16_t) +
         bricks_->values.capacity() * sizeof(float) + sizeof(Bricks);
}

namespace {

/// The occupancy of the voxels [low, high) of `grid` (either layout) as a dense grid of their
/// own (origin at zero), one brick at a time.
VoxelGrid denseCopy(const VoxelGrid& grid, const Eigen::Vector3i& low,
                    const Eigen::Vector3i& high) {
  const Eigen::Vector3i n = high - low;
  VoxelGrid copy(Box{Eigen::Vector3d::Zero(), n.cast<double>() * grid.resolution()},
                 grid.resolution());
  if (copy.dims() != n) throw std::logic_error("Esdf::truncated: a tile's grid is not its size");
  std::uint8_t* out = copy.occupancy().data();
  const int b = VoxelGrid::kBrick;
  for (int bx = low.x() / b; bx * b < high.x(); ++bx) {
    for (int by = low.y() / b; by * b < high.y(); ++by) {
      for (int bz = low.z() / b; bz * b < high.z(); ++bz) {
        if (grid.layout() == GridLayout::kBricked && !grid.brickHasObstacle(bx, by, bz)) continue;
        const Eigen::Vector3i from = (Eigen::Vector3i(bx, by, bz) * b).cwiseMax(low);
        const Eigen::Vector3i to =
            ((Eigen::Vector3i(bx, by, bz).array() + 1) * b).matrix().cwiseMin(high);
        for (int x = from.x(); x < to.x(); ++x) {
          for (int y = from.y(); y < to.y(); ++y) {
            std::uint8_t* row = out + copy.index(x - low.x(), y - low.y(), 0) - low.z();
            if (grid.layout() == GridLayout::kBricked) {
              const unsigned bits = grid.brickRow(x, y, bz);
              for (int z = from.z(); z < to.z(); ++z) row[z] = (bits >> (z & 7)) & 1;
            } else {
              for (int z = from.z(); z < to.z(); ++z) row[z] = grid.occupied({x, y, z}) ? 1 : 0;
            }
          }
        }
      }
    }
  }
  return copy;
}

/// Whether brick (bx, by, bz) of `grid` may hold an occupied voxel.
bool mayHoldObstacle(const VoxelGrid& grid, int bx, int by, int bz) {
  if (grid.layout() == GridLayout::kBricked) return grid.brickHasObstacle(bx, by, bz);
  const int b = VoxelGrid::kBrick;
  const Eigen::Vector3i from = Eigen::Vector3i(bx, by, bz) * b;
  const Eigen::Vector3i to =
      ((Eigen::Vector3i(bx, by, bz).array() + 1) * b).matrix().cwiseMin(grid.dims());
  for (int x = from.x(); x < to.x(); ++x) {
    for (int y = from.y(); y < to.y(); ++y) {
      for (int z = from.z(); z < to.z(); ++z) {
        if (grid.occupied(grid.index(x, y, z))) return true;
      }
    }
  }
  return false;
}

}  // namespace

Esdf Esdf::truncated(const VoxelGrid& grid, double truncation, int threads) {
  if (grid.size() == 0) throw InvalidArgument("Esdf::truncated: empty grid");
  if (!(truncation > 0.0 && truncation < INFINITY)) {
    throw InvalidArgument("Esdf::truncated: the truncation must be a positive finite distance");
  }
  if (threads < 0) throw InvalidArgument("Esdf::truncated: threads must be >= 0");
  if (threads == 0) {
    threads = grid.size() < kParallelVoxels
                  ? 1
                  : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  }
  if (truncation > kMostTruncationVoxels * grid.resolution()) {
    throw InvalidArgument("Esdf::truncated: a truncation of " + std::to_string(truncation) +
                          " m is more than 90 voxels");
  }
  Esdf esdf;
  esdf.setGeometry(grid);
  esdf.truncation_ = truncation;
  const auto limit = static_cast<float>(truncation);
  const auto half_voxel = static_cast<float>(0.5 * grid.resolution());
  const int b = VoxelGrid::kBrick;
  const Eigen::Vector3i& n = grid.dims();
  const Eigen::Vector3i bricks = (n.array() + b - 1) / b;
  auto store = std::make_shared<Bricks>();
  std::fill(std::begin(store->far), std::end(store->far), kBeyond);
  std::fill(std::begin(store->deep), std::end(store->deep), static_cast<std::int16_t>(-kBeyond));
  // The values the dense field computes from each squared distance (cappedDistance()).
  store->values.assign(std::size_t{1} << 16, 0.0f);
  for (std::int32_t code = 1; code < kBeyond; ++code) {
    const float value = std::sqrt(static_cast<float>(code)) * half_voxel;
    store->values[static_cast<std::uint16_t>(code)] = value;
    store->values[static_cast<std::uint16_t>(-code)] = -value;
  }
  store->values[static_cast<std::uint16_t>(kBeyond)] = limit;
  store->values[static_cast<std::uint16_t>(-kBeyond)] = -limit;
  // The least squared distance (half voxels) the dense field puts at or past T, as it compares
  // (in float, cappedDistance()); every one below it is within T (the comparison is monotone).
  std::int32_t beyond = 0;
  while (std::sqrt(static_cast<float>(beyond)) * half_voxel < limit) ++beyond;
  store->table.assign(static_cast<std::size_t>(bricks.cast<double>().prod()), store->far);
  esdf.brick_strides_[0] = static_cast<std::size_t>(bricks.y()) * bricks.z();
  esdf.brick_strides_[1] = static_cast<std::size_t>(bricks.z());
  // A cube within T of a voxel's centre is within `margin` voxels of the voxel on every axis
  // (its offset k gives a distance of at least (k - 1/2) voxels).
  const int margin = static_cast<int>(std::ceil(truncation / grid.resolution())) + 1;
  const int margin_bricks = (margin + b - 1) / b;
  constexpr int kTile = 16;  // bricks per tile side in x and y
  // The largest tile's part must be within the exact transform's size.
  checkTransformable(
      Eigen::Vector3i(kTile * b + 2 * margin, kTile * b + 2 * margin, n.z()).cwiseMin(n),
      "Esdf::truncated (a tile)");
  const int tiles_x = (bricks.x() + kTile - 1) / kTile;
  const int tiles_y = (bricks.y() + kTile - 1) / kTile;
  std::atomic<int> next_tile{0};
  std::mutex chunks_mutex;
  const auto tile = [&](int t) {
    const Eigen::Vector3i first(t / tiles_y * kTile, t % tiles_y * kTile, 0);
    const Eigen::Vector3i last(std::min(first.x() + kTile, bricks.x()),
                               std::min(first.y() + kTile, bricks.y()), bricks.z());
    // The heights holding an obstacle within the margin of the tile's columns.
    int z_low = bricks.z();
    int z_high = -1;
    for (int bx = std::max(0, first.x() - margin_bricks);
         bx < std::min(bricks.x(), last.x() + margin_bricks); ++bx) {
      for (int by = std::max(0, first.y() - margin_bricks);
           by < std::min(bricks.y(), last.y() + margin_bricks); ++by) {
        for (int bz = 0; bz < bricks.z(); ++bz) {
          if (!mayHoldObstacle(grid, bx, by, bz)) continue;
          z_low = std::min(z_low, bz);
          z_high = std::max(z_high, bz);
        }
      }
    }
    if (z_high < 0) return;  // no obstacle within T: every brick stays at +T
    const Eigen::Vector3i low =
        (Eigen::Vector3i(first.x() * b - margin, first.y() * b - margin, z_low * b - margin))
            .cwiseMax(Eigen::Vector3i::Zero());
    const Eigen::Vector3i high =
        Eigen::Vector3i(last.x() * b + margin, last.y() * b + margin, (z_high + 1) * b + margin)
            .cwiseMin(n);
    const VoxelGrid part = denseCopy(grid, low, high);
    std::vector<std::int32_t> field;
    signedSquaredDistances(part, 1, field, beyond);
    // A voxel's code: its squared distance within T, signed; kBeyond past T.
    const auto code = [&](std::size_t i) -> std::int16_t {
      const std::int32_t squared = decodeSigned(field[i]);
      const std::int16_t magnitude =
          squared < beyond ? static_cast<std::int16_t>(squared) : kBeyond;
      return field[i] < 0 ? static_cast<std::int16_t>(-magnitude) : magnitude;
    };
    // The bricks of the tile with a value strictly inside (-T, T); the others share +T or -T.
    std::vector<std::int16_t> values;
    std::vector<std::size_t> owners;
    std::int16_t brick[kBrickVoxels];
    for (int bx = first.x(); bx < last.x(); ++bx) {
      for (int by = first.y(); by < last.y(); ++by) {
        for (int bz = 0; bz < bricks.z(); ++bz) {
          const Eigen::Vector3i from = Eigen::Vector3i(bx, by, bz) * b;
          if (from.z() + b <= low.z() || from.z() >= high.z()) continue;  // beyond the margin
          // Voxels past the grid's end are never read (+T keeps such a brick shared), and
          // those below or above the tile's part are more than T from every obstacle.
          const int z_from = std::max(from.z(), low.z());
          const int z_to = std::min(from.z() + b, high.z());
          bool all_far = true;
          bool all_deep = true;
          for (int i = 0; i < b * b; ++i) {
            const int x = from.x() + (i >> 3);
            const int y = from.y() + (i & 7);
            std::int16_t* row = brick + i * b;
            std::fill(row, row + b, kBeyond);
            if (x >= n.x() || y >= n.y()) continue;
            const std::size_t start = part.index(x - low.x(), y - low.y(), z_from - low.z());
            for (int z = z_from; z < z_to; ++z) row[z - from.z()] = code(start + (z - z_from));
            for (int k = 0; k < b; ++k) {
              all_far = all_far && row[k] == kBeyond;
              all_deep = all_deep && row[k] == -kBeyond;
            }
          }
          const std::size_t index =
              (static_cast<std::size_t>(bx) * bricks.y() + by) * bricks.z() + bz;
          if (all_deep) store->table[index] = store->deep;
          if (all_far || all_deep) continue;
          owners.push_back(index);
          values.insert(values.end(), brick, brick + kBrickVoxels);
        }
      }
    }
    if (owners.empty()) return;
    auto chunk = std::make_unique<std::int16_t[]>(values.size());
    std::copy(values.begin(), values.end(), chunk.get());
    // Each tile writes its own entries of the table.
    for (std::size_t k = 0; k < owners.size(); ++k) {
      store->table[owners[k]] = chunk.get() + k * kBrickVoxels;
    }
    const std::lock_guard<std::mutex> lock(chunks_mutex);
    store->allocated += owners.size();
    store->chunks.push_back(std::move(chunk));
  };
  inParallel(static_cast<std::size_t>(threads), threads, [&](std::size_t, std::size_t) {
    for (int t = next_tile++; t < tiles_x * tiles_y; t = next_tile++) tile(t);
  });
  esdf.brick_table_ = store->table.data();
  esdf.code_values_ = store->values.data();
  esdf.bricks_ = std::move(store);
  return esdf;
}

template <bool kWithGradient>
void Esdf::batch(const Eigen::Vector3d* points, std::size_t count, double* distances,
                 Eigen::Vector3d* gradients) const {
  const auto one = [&](std::size_t i) {
    distances[i] =
        interpolate<kWithGradient>(points[i], kWithGradient ? &gradients[i] : nullptr, nullptr);
  };
  if (brick_table_) {  // a truncated field's bricks: one at a time
    for (std::size_t i = 0; i < count; ++i) one(i);
    return;
  }
  // Two points at a time, a point to a lane of SSE2 pairs, through interpolate()'s arithmetic:
  // per lane the same operations in the same order (for each x side on its own), so the same
  // values bit for bit. Chunks of kChunk pairs: the cells of chunk j + 1 found and their
  // corners' cache lines requested into the outer caches (a prefetch to L1 would wait for its
  // few fill buffers) before chunk j is interpolated.
  using Pair = double __attribute__((vector_size(16)));
  using Mask = std::int64_t __attribute__((vector_size(16)));
  using Indices = std::int32_t __attribute__((vector_size(8)));
  struct Cells {
    std::size_t base[2];
    Pair fraction[3];
    Pair scale[3];
    Pair poison;
  };
  const auto cellsOf = [this](const Eigen::Vector3d& a, const Eigen::Vector3d& b, Cells& cells) {
    const Pair zero = {0.0, 0.0};
    cells.base[0] = 0;
    cells.base[1] = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const Pair raw = Pair{a[axis], b[axis]} * inverse_resolution_ - shift_[axis];
      // std::max(0.0, raw), then std::min(.., upper), as the standard library selects: a NaN
      // coordinate becomes 0.
      const Pair low = zero < raw ? raw : zero;
      const Pair upper = {upper_[axis], upper_[axis]};
      const Pair scaled = upper < low ? upper : low;
      const Mask unclamped = raw == scaled;
      cells.scale[axis] = unclamped ? Pair{gradient_scale_[axis], gradient_scale_[axis]} : zero;
      const Pair highest = {lower_corner_[axis], lower_corner_[axis]};
      // Truncation to 32 bits is the 64-bit one: an axis has at most checkTransformable()'s
      // 23,000-odd voxels.
      const Indices corner = __builtin_convertvector(highest < scaled ? highest : scaled, Indices);
      cells.fraction[axis] = scaled - __builtin_convertvector(corner, Pair);
      cells.base[0] += static_cast<std::size_t>(corner[0]) * strides_[axis];
      cells.base[1] += static_cast<std::size_t>(corner[1]) * strides_[axis];
    }
    cells.poison = Pair{a.x(), b.x()} * 0.0 + Pair{a.y(), b.y()} * 0.0 + Pair{a.z(), b.z()} * 0.0;
  };
  const std::size_t* step = neighbour_step_;
  const auto blend = [&](const Cells& cells, std::size_t i) {
    const float* a = values_.data() + cells.base[0];
    const float* b = values_.data() + cells.base[1];
    const auto corner = [&](std::size_t offset) { return Pair{a[offset], b[offset]}; };
    const Pair c000 = corner(0);
    const Pair c001 = corner(step[2]);
    const Pair c010 = corner(step[1]);
    const Pair c011 = corner(step[1] + step[2]);
    const Pair c100 = corner(step[0]);
    const Pair c101 = corner(step[0] + step[2]);
    const Pair c110 = corner(step[0] + step[1]);
    const Pair c111 = corner(step[0] + step[1] + step[2]);
    const Pair tx = cells.fraction[0];
    const Pair ty = cells.fraction[1];
    const Pair tz = cells.fraction[2];
    const Pair dz_low0 = c001 - c000;  // interpolate()'s dz_low, the x0 side
    const Pair dz_low1 = c101 - c100;
    const Pair dz_high0 = c011 - c010;
    const Pair dz_high1 = c111 - c110;
    const Pair e00 = c000 + dz_low0 * tz;  // e0, x0 side
    const Pair e01 = c100 + dz_low1 * tz;
    const Pair e10 = c010 + dz_high0 * tz;
    const Pair e11 = c110 + dz_high1 * tz;
    const Pair dy0 = e10 - e00;
    const Pair dy1 = e11 - e01;
    const Pair c0 = e00 + dy0 * ty;
    const Pair c1 = e01 + dy1 * ty;
    const Pair dx = c1 - c0;
    const Pair value = c0 + dx * tx + cells.poison;
    distances[i] = value[0];
    distances[i + 1] = value[1];
    if constexpr (kWithGradient) {
      const Pair dz0 = dz_low0 + (dz_high0 - dz_low0) * ty;
      const Pair dz1 = dz_low1 + (dz_high1 - dz_low1) * ty;
      const Pair gx = dx * cells.scale[0];
      const Pair gy = (dy0 + (dy1 - dy0) * tx) * cells.scale[1];
      const Pair gz = (dz0 + (dz1 - dz0) * tx) * cells.scale[2];
      gradients[i] = {gx[0], gy[0], gz[0]};
      gradients[i + 1] = {gx[1], gy[1], gz[1]};
    }
  };
  constexpr std::size_t kChunk = 8;
  const std::size_t pairs = count / 2;
  Cells cells[2][kChunk];
  const auto find = [&](std::size_t first, Cells* out) {
    const std::size_t n = std::min(kChunk, pairs - first);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = 2 * (first + k);
      cellsOf(points[i], points[i + 1], out[k]);
      for (const std::size_t base : out[k].base) {
        const float* v = values_.data() + base;
        __builtin_prefetch(v, 0, 1);
        __builtin_prefetch(v + step[1] + step[2], 0, 1);
        __builtin_prefetch(v + step[0], 0, 1);
        __builtin_prefetch(v + step[0] + step[1] + step[2], 0, 1);
      }
    }
  };
  if (pairs > 0) find(0, cells[0]);
  for (std::size_t first = 0, j = 0; first < pairs; first += kChunk, j ^= 1) {
    if (first + kChunk < pairs) find(first + kChunk, cells[j ^ 1]);
    const std::size_t n = std::min(kChunk, pairs - first);
    for (std::size_t k = 0; k < n; ++k) blend(cells[j][k], 2 * (first + k));
  }
  if (count % 2 == 1) one(count - 1);
}

void Esdf::distances(std::span<const Eigen::Vector3d> points, std::span<double> distances) const {
  if (distances.size() != points.size()) {
    throw InvalidArgument("Esdf::distances: " + std::to_string(distances.size()) +
                          " distances for " + std::to_string(points.size()) + " points");
  }
  batch<false>(points.data(), points.size(), distances.data(), nullptr);
}

void Esdf::distancesWithGradients(std::span<const Eigen::Vector3d> points,
                                  std::span<double> distances,
                                  std::span<Eigen::Vector3d> gradients) const {
  if (distances.size() != points.size() || gradients.size() != points.size()) {
    throw InvalidArgument("Esdf::distancesWithGradients: " + std::to_string(distances.size()) +
                          " distances and " + std::to_string(gradients.size()) + " gradients for " +
                          std::to_string(points.size()) + " points");
  }
  batch<true>(points.data(), points.size(), distances.data(), gradients.data());
}

double Esdf::centreBound(const Eigen::Vector3d& point) const {
  if (values_.empty() && !brick_table_) return -INFINITY;
  std::size_t lower[3];
  double low[3];   // offset (voxels) from the lower centre along each axis
  double high[3];  // and from the upper one
  for (int axis = 0; axis < 3; ++axis) {
    const double raw = point[axis] * inverse_resolution_ - shift_[axis];
    if (!std::isfinite(raw)) return -INFINITY;
    lower[axis] = static_cast<std::size_t>(
        static_cast<std::int64_t>(std::min(std::max(0.0, std::floor(raw)), lower_corner_[axis])));
    low[axis] = raw - static_cast<double>(lower[axis]);
    // On a one-voxel axis both "corners" are the one centre.
    high[axis] = unit_step_[axis] != 0 ? low[axis] - 1.0 : low[axis];
  }
  double best = -INFINITY;
  for (int corner = 0; corner < 8; ++corner) {
    std::size_t cell[3];
    double squared = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const bool upper = (corner >> axis) & 1;
      cell[axis] = lower[axis] + (upper ? unit_step_[axis] : 0);
      const double offset = upper ? high[axis] : low[axis];
      squared += offset * offset;
    }
    best = std::max(best, valueAt(cell[0], cell[1], cell[2]) - resolution_ * std::sqrt(squared));
  }
  return best;
}

double Esdf::exactDistanceAbove(const Eigen::Vector3d& point, double limit, double enough,
                                double lower) const {
  if (brick_table_) {
    return nearestCube(
        NearestCubeSearch<BrickRows>{
            {brick_table_, {brick_strides_[0], brick_strides_[1]}, code_values_}},
        point, limit, enough, lower);
  }
  if (values_.empty()) return limit;
  return nearestCube(NearestCubeSearch<DenseRows>{{values_.data(),
                                                   {static_cast<std::int64_t>(strides_[0]),
                                                    static_cast<std::int64_t>(strides_[1])}}},
                     point, limit, enough, lower);
}

template <typename Search>
double Esdf::nearestCube(Search search, const Eigen::Vector3d& point, double limit, double enough,
                         double lower) const {
  double centre_offset2 = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    search.scaled[axis] = (point[axis] - origin_[axis]) * inverse_resolution_;
    if (!std::isfinite(search.scaled[axis])) return limit;
    search.cell[axis] = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::floor(search.scaled[axis])), 0, dims_[axis] - 1);
    const double offset = search.scaled[axis] - (static_cast<double>(search.cell[axis]) + 0.5);
    centre_offset2 += offset * offset;
  }
  // In voxel units from here on. The nearest cube lies in a shell about the point: within a
  // lower bound of the distance (`lower`) every voxel is free, and within an upper bound
  // (the voxel's centre value, exact, and the way to it) there is a cube; both with float
  // rounding's slack. Only the shell is searched.
  const float raw =
      valueAt(static_cast<std::size_t>(search.cell[0]), static_cast<std::size_t>(search.cell[1]),
              static_cast<std::size_t>(search.cell[2]));
  // At the cap (the grid's diagonal, farther than any cube of the grid is from a voxel
  // centre): no voxel is occupied.
  if (raw >= static_cast<float>(max_distance_)) return limit;
  const double stored = raw * inverse_resolution_;
  double reach = limit * inverse_resolution_;
  // A truncated value at +T says only that the cube is at least T from the centre, no bound
  // above: the search goes out to the limit (the lower bounds still skip the ball inside).
  const bool beyond_truncation = raw >= static_cast<float>(truncation_);
  if (stored >= 0.0 && !beyond_truncation) {
    reach = std::min(reach, stored + std::sqrt(centre_offset2) + 1e-4);
  }
  const double inner = std::max(0.0, lower * inverse_resolution_ - 1e-4);
  for (int axis = 0; axis < 3; ++axis) {
    search.from[axis] = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::floor(search.scaled[axis] - reach)));
    search.to[axis] = std::min<std::int64_t>(
        dims_[axis] - 1, static_cast<std::int64_t>(std::floor(search.scaled[axis] + reach)));
  }
  search.inner2 = inner * inner;
  search.best2 = reach * reach;
  const double enough_voxels = enough * inverse_resolution_;
  // Stop early only on a cube provably nearer than `enough` (its distance rounds below it):
  // one at `enough` itself, within rounding, must not end the search for a nearer one.
  search.enough2 = enough > 0.0 ? enough_voxels * enough_voxels * (1.0 - 1e-12) : -1.0;
  search.run();
  if (search.found && search.best2 == 0.0) return -0.5 * resolution_;  // in (or on) a cube
  const double best = std::sqrt(search.best2) * resolution_;
  if (search.found) return std::min(best, limit);
  return limit;  // no cube within reach: at least the limit
}

IncrementalEsdf::IncrementalEsdf(VoxelGrid grid) { rebuild(std::move(grid)); }

void IncrementalEsdf::rebuild(VoxelGrid grid) {
  if (grid.size() == 0) throw InvalidArgument("IncrementalEsdf: empty grid");
  checkTransformable(grid.dims(), "IncrementalEsdf");
  grid_ = std::move(grid);
  CubeTransform transform(grid_.dims());
  for (int sign = 0; sign < 2; ++sign) {
    std::vector<std::int32_t>* pass = pass_[sign];
    for (int k = 0; k < 3; ++k) pass[k].resize(grid_.size());
    transform.rows(grid_.occupancy().data(), sign == 0 ? 1 : 0, pass[0].data());
    transform.alongY(pass[0].data(), pass[1].data());
    transform.alongZ(pass[1].data(), pass[2].data());
  }
  const Eigen::Vector3i& n = grid_.dims();
  lines_ += 2 * (static_cast<std::size_t>(n.x()) * n.y() + static_cast<std::size_t>(n.x()) * n.z() +
                 static_cast<std::size_t>(n.y()) * n.z());
  values_.resize(grid_.size());
  const auto cap = static_cast<float>((n.cast<double>() * grid_.resolution()).norm());
  const auto half_voxel = static_cast<float>(0.5 * grid_.resolution());
  const std::uint8_t* occupancy = grid_.occupancy().data();
  for (std::size_t i = 0; i < values_.size(); ++i) {
    values_[i] = signedDistance(pass_[0][2][i], pass_[1][2][i], occupancy[i] != 0, half_voxel, cap);
  }
}

std::size_t IncrementalEsdf::update(const std::vector<std::uint8_t>& occupancy) {
  if (occupancy.size() != grid_.size()) {
    throw InvalidArgument("IncrementalEsdf::update: " + std::to_string(occupancy.size()) +
                          " voxels for a grid of " + std::to_string(grid_.size()));
  }
  std::vector<std::uint8_t>& current = grid_.occupancy();
  std::vector<std::size_t> changed;
  // Eight voxels at a time where their bytes are equal (a frame changes few).
  for (std::size_t begin = 0; begin < current.size(); begin += 8) {
    const std::size_t end = std::min(begin + 8, current.size());
    if (end - begin == 8 && std::memcmp(&current[begin], &occupancy[begin], 8) == 0) continue;
    for (std::size_t i = begin; i < end; ++i) {
      if ((current[i] != 0) != (occupancy[i] != 0)) {
        changed.push_back(i);
        current[i] = occupancy[i] != 0 ? 1 : 0;
      }
    }
  }
  if (changed.empty()) return 0;
  const Eigen::Vector3i& n = grid_.dims();
  const auto nx = static_cast<std::size_t>(n.x());
  const auto ny = static_cast<std::size_t>(n.y());
  const auto nz = static_cast<std::size_t>(n.z());
  const std::size_t slab = ny * nz;
  CubeTransform transform(n);
  // The x-lines (y, z) holding a changed voxel: the same for both signs.
  std::vector<std::uint8_t> x_dirty(slab, 0);
  for (const std::size_t voxel : changed) x_dirty[voxel % slab] = 1;
  std::vector<std::uint8_t> bytes(nx);
  std::vector<std::int32_t> row(nx);
  // A pass's changed entries, for the next pass's lines, and the same by line.
  std::vector<LineChange> changes;
  std::vector<LineChange> sorted;
  std::vector<std::uint32_t> starts;
  // The voxels whose value may change: the changed ones and those whose pass 3 changed.
  std::vector<std::size_t> touched = changed;
  for (int sign = 0; sign < 2; ++sign) {
    const std::uint8_t target = sign == 0 ? 1 : 0;
    std::vector<std::int32_t>* pass = pass_[sign];
    // Pass 1: the x-lines holding a changed voxel; their changes are on the y-lines (x, z).
    changes.clear();
    for (std::size_t line = 0; line < slab; ++line) {
      if (!x_dirty[line]) continue;
      ++lines_;
      for (std::size_t x = 0; x < nx; ++x) bytes[x] = current[line + x * slab];
      transformColumn(bytes.data(), n.x(), target, row.data());
      const auto y = static_cast<int>(line / nz);
      const std::size_t z = line % nz;
      for (std::size_t x = 0; x < nx; ++x) {
        std::int32_t& entry = pass[0][line + x * slab];
        if (entry == row[x]) continue;
        changes.push_back({static_cast<std::uint32_t>(x * nz + z), y, entry});
        entry = row[x];
      }
    }
    // Pass 2: those y-lines; their changes are on the columns (x, y).
    byLine(changes, nx * nz, sorted, starts);
    changes.clear();
    for (std::size_t line = 0; line < nx * nz; ++line) {
      if (starts[line] == starts[line + 1]) continue;
      const std::size_t x = line / nz;
      const std::size_t z = line % nz;
      lines_ += transform.update(
          pass[0].data(), pass[1].data(), x * slab + z, n.y(), nz, sorted.data() + starts[line],
          sorted.data() + starts[line + 1], [&](int y, std::int32_t old) {
            changes.push_back({static_cast<std::uint32_t>(x * ny + y), static_cast<int>(z), old});
          });
    }
    // Pass 3: those columns (contiguous, the pass with the most lines); their altered entries
    // are values to recompute.
    byLine(changes, nx * ny, sorted, starts);
    for (std::size_t column = 0; column < nx * ny; ++column) {
      if (starts[column] == starts[column + 1]) continue;
      lines_ += transform.update(pass[1].data(), pass[2].data(), column * nz, n.z(), 1,
                                 sorted.data() + starts[column], sorted.data() + starts[column + 1],
                                 [&](int z, std::int32_t) { touched.push_back(column * nz + z); });
    }
  }
  const auto cap = static_cast<float>((n.cast<double>() * grid_.resolution()).norm());
  const auto half_voxel = static_cast<float>(0.5 * grid_.resolution());
  for (const std::size_t i : touched) {
    values_[i] = signedDistance(pass_[0][2][i], pass_[1][2][i], current[i] != 0, half_voxel, cap);
  }
  return changed.size();
}

}  // namespace kinolab
