// IncrementalEsdf: the unsigned cube distance transform in the order x, y, z, every pass's
// result kept, and updated line by line where the occupancy changes.
#include <cstring>
#include <string>

#include "esdf_transform.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {
namespace {

using esdf_detail::EnvelopeScratch;
using esdf_detail::kBlock;
using esdf_detail::kNoSite;
using esdf_detail::transformColumn;
using esdf_detail::transformLine;

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

/// The three passes of the cube distance transform in IncrementalEsdf's order over a grid of
/// `dims` (x slowest, z fastest): pass 1 along x (rows()), pass 2 along y (within each x-slab,
/// lines over iy for every iz; alongY()) and pass 3 along z (alongZ()), each pass into the next
/// one's array; and one line of pass 2 or 3 at a time (line(), update()).
struct LineTransform {
  explicit LineTransform(const Eigen::Vector3i& grid_dims)
      : dims(grid_dims),
        slab(static_cast<std::size_t>(dims.y()) * dims.z()),
        scratch(dims.maxCoeff()),
        in(static_cast<std::size_t>(kBlock) * dims.maxCoeff()),
        out(in.size()),
        suspects(static_cast<std::size_t>(dims.maxCoeff())) {}

  /// transformLine() over lines of `length` with this transform's scratch space.
  auto envelope(int length) {
    return [this, length](const std::int32_t* f, std::int32_t* d) {
      transformLine(f, d, length, scratch);
    };
  }
  /// Pass 1, along x: every x-line of `occupancy` into `squared`, as transformColumn() has
  /// it, by two sweeps over the x-slabs (every line at once, contiguous).
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
  /// Pass 2, every x-slab, from `from` into `to` (another array).
  void alongY(const std::int32_t* from, std::int32_t* to) {
    const auto nx = static_cast<std::size_t>(dims.x());
    for (std::size_t ix = 0; ix < nx; ++ix) {
      transformStrided(from, to, ix * slab, static_cast<std::size_t>(dims.z()), dims.y(),
                       static_cast<std::size_t>(dims.z()), in, out, envelope(dims.y()));
    }
  }
  /// Pass 3, along z: every column of `from` into `to` (another array).
  void alongZ(const std::int32_t* from, std::int32_t* to) {
    const auto nz = static_cast<std::size_t>(dims.z());
    const std::size_t count = static_cast<std::size_t>(dims.x()) * dims.y();
    for (std::size_t column = 0; column < count; ++column) {
      transformLine(from + column * nz, to + column * nz, dims.z(), scratch);
    }
  }
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
  std::size_t slab;
  EnvelopeScratch scratch;
  std::vector<std::int32_t> in;
  std::vector<std::int32_t> out;
  std::vector<std::uint8_t> suspects;  // update()'s
};

/// Makes `occupancy` (0 free, else occupied) the grid's `current` (0 or 1 a voxel); returns
/// the voxels that changed occupancy, in grid order.
std::vector<std::size_t> applyOccupancy(std::span<std::uint8_t> current,
                                        const std::vector<std::uint8_t>& occupancy) {
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
  return changed;
}

/// One update of the passes after the voxels `changed` changed occupancy (the grid holds the
/// new one), a sign at a time: pass 1 on the x-lines holding a changed voxel, pass 2 on the
/// y-lines whose pass-1 entries changed, pass 3 on the columns whose pass-2 entries changed.
class PassUpdate {
 public:
  PassUpdate(const VoxelGrid& grid, const std::vector<std::size_t>& changed)
      : current_(grid.occupancy().data()),
        n_(grid.dims()),
        nx_(static_cast<std::size_t>(n_.x())),
        ny_(static_cast<std::size_t>(n_.y())),
        nz_(static_cast<std::size_t>(n_.z())),
        slab_(ny_ * nz_),
        transform_(n_),
        x_dirty_(slab_, 0),
        bytes_(nx_),
        row_(nx_) {
    // The x-lines (y, z) holding a changed voxel: the same for both signs.
    for (const std::size_t voxel : changed) x_dirty_[voxel % slab_] = 1;
  }

  /// Updates `pass`, one sign's results of the three passes (the distances to the voxels of
  /// occupancy `target`); appends the voxels whose pass 3 changed to `touched`. Returns the
  /// lines transformed in full.
  std::size_t run(std::uint8_t target, std::vector<std::int32_t>* pass,
                  std::vector<std::size_t>& touched) {
    std::size_t lines = alongX(target, pass[0]);
    lines += alongY(pass[0], pass[1]);
    return lines + alongZ(pass[1], pass[2], touched);
  }

 private:
  /// Pass 1: the x-lines holding a changed voxel; their changes are on the y-lines (x, z).
  std::size_t alongX(std::uint8_t target, std::vector<std::int32_t>& result) {
    changes_.clear();
    std::size_t lines = 0;
    for (std::size_t line = 0; line < slab_; ++line) {
      if (!x_dirty_[line]) continue;
      ++lines;
      for (std::size_t x = 0; x < nx_; ++x) bytes_[x] = current_[line + x * slab_];
      transformColumn(bytes_.data(), n_.x(), target, row_.data());
      const auto y = static_cast<int>(line / nz_);
      const std::size_t z = line % nz_;
      for (std::size_t x = 0; x < nx_; ++x) {
        std::int32_t& entry = result[line + x * slab_];
        if (entry == row_[x]) continue;
        changes_.push_back({static_cast<std::uint32_t>(x * nz_ + z), y, entry});
        entry = row_[x];
      }
    }
    return lines;
  }

  /// Pass 2: the y-lines pass 1 changed; their changes are on the columns (x, y).
  std::size_t alongY(const std::vector<std::int32_t>& from, std::vector<std::int32_t>& to) {
    byLine(changes_, nx_ * nz_, sorted_, starts_);
    changes_.clear();
    std::size_t lines = 0;
    for (std::size_t line = 0; line < nx_ * nz_; ++line) {
      if (starts_[line] == starts_[line + 1]) continue;
      const std::size_t x = line / nz_;
      const std::size_t z = line % nz_;
      lines += transform_.update(
          from.data(), to.data(), x * slab_ + z, n_.y(), nz_, sorted_.data() + starts_[line],
          sorted_.data() + starts_[line + 1], [&](int y, std::int32_t old) {
            changes_.push_back({static_cast<std::uint32_t>(x * ny_ + y), static_cast<int>(z), old});
          });
    }
    return lines;
  }

  /// Pass 3: the columns pass 2 changed (contiguous, the pass with the most lines); their
  /// altered entries are values to recompute, into `touched`.
  std::size_t alongZ(const std::vector<std::int32_t>& from, std::vector<std::int32_t>& to,
                     std::vector<std::size_t>& touched) {
    byLine(changes_, nx_ * ny_, sorted_, starts_);
    std::size_t lines = 0;
    for (std::size_t column = 0; column < nx_ * ny_; ++column) {
      if (starts_[column] == starts_[column + 1]) continue;
      lines +=
          transform_.update(from.data(), to.data(), column * nz_, n_.z(), 1,
                            sorted_.data() + starts_[column], sorted_.data() + starts_[column + 1],
                            [&](int z, std::int32_t) { touched.push_back(column * nz_ + z); });
    }
    return lines;
  }

  const std::uint8_t* current_;
  Eigen::Vector3i n_;
  std::size_t nx_;
  std::size_t ny_;
  std::size_t nz_;
  std::size_t slab_;
  LineTransform transform_;
  std::vector<std::uint8_t> x_dirty_;
  std::vector<std::uint8_t> bytes_;
  std::vector<std::int32_t> row_;
  // A pass's changed entries, for the next pass's lines, and the same by line.
  std::vector<LineChange> changes_;
  std::vector<LineChange> sorted_;
  std::vector<std::uint32_t> starts_;
};

}  // namespace

IncrementalEsdf::IncrementalEsdf(VoxelGrid grid) { rebuild(std::move(grid)); }

void IncrementalEsdf::rebuild(VoxelGrid grid) {
  if (grid.size() == 0) throw InvalidArgument("IncrementalEsdf: empty grid");
  esdf_detail::checkTransformable(grid.dims(), "IncrementalEsdf");
  grid_ = std::move(grid);
  LineTransform transform(grid_.dims());
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
    values_[i] = esdf_detail::signedDistance(pass_[0][2][i], pass_[1][2][i], occupancy[i] != 0,
                                             half_voxel, cap);
  }
}

std::size_t IncrementalEsdf::update(const std::vector<std::uint8_t>& occupancy) {
  if (occupancy.size() != grid_.size()) {
    throw InvalidArgument("IncrementalEsdf::update: " + std::to_string(occupancy.size()) +
                          " voxels for a grid of " + std::to_string(grid_.size()));
  }
  const std::vector<std::size_t> changed = applyOccupancy(grid_.mutableOccupancy(), occupancy);
  if (changed.empty()) return 0;
  PassUpdate passes(grid_, changed);
  // The voxels whose value may change: the changed ones and those whose pass 3 changed.
  std::vector<std::size_t> touched = changed;
  for (int sign = 0; sign < 2; ++sign) {
    lines_ += passes.run(sign == 0 ? 1 : 0, pass_[sign], touched);
  }
  const auto cap = static_cast<float>((grid_.dims().cast<double>() * grid_.resolution()).norm());
  const auto half_voxel = static_cast<float>(0.5 * grid_.resolution());
  const std::uint8_t* current = grid_.occupancy().data();
  for (const std::size_t i : touched) {
    values_[i] = esdf_detail::signedDistance(pass_[0][2][i], pass_[1][2][i], current[i] != 0,
                                             half_voxel, cap);
  }
  return changed.size();
}

}  // namespace kinolab
