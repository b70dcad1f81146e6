// Esdf::truncated(): a sparse world's field, truncated at T and stored on 8 x 8 x 8 bricks,
// computed tile by tile by the exact transform.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "esdf_transform.hpp"
#include "kinolab/core/error.hpp"
#include "kinolab/world/esdf.hpp"

namespace kinolab {

struct Esdf::Bricks {
  std::vector<const std::int16_t*> table;
  std::vector<std::unique_ptr<std::int16_t[]>> chunks;  // the allocated bricks, one per tile
  std::size_t allocated = 0;
  std::int16_t far[kBrickVoxels];
  std::int16_t deep[kBrickVoxels];
  std::vector<float> values;        // of each code, as 16 bits
  ValueArray<std::int16_t> stored;  // the bricks of a field from a cache file (fromBricks)
};

std::size_t Esdf::allocatedBricks() const { return bricks_ ? bricks_->allocated : 0; }

std::size_t Esdf::memoryBytes() const {
  if (!bricks_) return values_.bytes();
  return bricks_->table.capacity() * sizeof(const std::int16_t*) +
         (bricks_->stored.empty() ? bricks_->allocated * kBrickVoxels * sizeof(std::int16_t)
                                  : bricks_->stored.bytes()) +
         bricks_->values.capacity() * sizeof(float) + sizeof(Bricks);
}

namespace {

using esdf_detail::decodeSigned;

// A voxel's code in a truncated field: +-(squared distance in half voxels) within T, else
// +-kBeyond (T itself); 90 voxels of truncation square to 32,400 half voxels.
constexpr std::int16_t kBeyond = 32767;
constexpr double kMostTruncationVoxels = 90.0;

/// The occupancy of the voxels [low, high) of `grid` (either layout) as a dense grid of their
/// own (origin at zero), one brick at a time.
VoxelGrid denseCopy(const VoxelGrid& grid, const Eigen::Vector3i& low,
                    const Eigen::Vector3i& high) {
  const Eigen::Vector3i n = high - low;
  VoxelGrid copy(Box{Eigen::Vector3d::Zero(), n.cast<double>() * grid.resolution()},
                 grid.resolution());
  if (copy.dims() != n) throw std::logic_error("Esdf::truncated: a tile's grid is not its size");
  std::uint8_t* out = copy.mutableOccupancy().data();
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

/// The values a truncated field's codes read, as the dense field computes them from each
/// squared distance (cappedDistance()): code c (as 16 bits) gives +-sqrt(|c|) half voxels,
/// signed as c, and +-kBeyond gives +-`limit` (T).
std::vector<float> codeValues(float half_voxel, float limit) {
  std::vector<float> values(std::size_t{1} << 16, 0.0f);
  for (std::int32_t code = 1; code < kBeyond; ++code) {
    const float value = std::sqrt(static_cast<float>(code)) * half_voxel;
    values[static_cast<std::uint16_t>(code)] = value;
    values[static_cast<std::uint16_t>(-code)] = -value;
  }
  values[static_cast<std::uint16_t>(kBeyond)] = limit;
  values[static_cast<std::uint16_t>(-kBeyond)] = -limit;
  return values;
}

/// The least squared distance (half voxels) the dense field puts at or past T (`limit`), as it
/// compares (in float, cappedDistance()); every one below it is within T (the comparison is
/// monotone).
std::int32_t leastBeyond(float half_voxel, float limit) {
  std::int32_t beyond = 0;
  while (std::sqrt(static_cast<float>(beyond)) * half_voxel < limit) ++beyond;
  return beyond;
}

/// A tile's bricks holding values of their own, in one chunk of `count` bricks.
struct TileBricks {
  std::unique_ptr<std::int16_t[]> chunk;
  std::size_t count = 0;
};

/// A truncated field's tiles: 16 x 16 bricks in x and y and every height holding an obstacle,
/// each computed on a dense copy of its part of the grid with a margin of the truncation, by
/// the exact transform limited to T.
class TruncatedTiles {
 public:
  static constexpr int kTile = 16;  // bricks per tile side in x and y

  /// `beyond`: leastBeyond() of the truncation.
  TruncatedTiles(const VoxelGrid& grid, double truncation, std::int32_t beyond)
      : grid_(grid),
        n_(grid.dims()),
        bricks_((n_.array() + kBrick - 1) / kBrick),
        beyond_(beyond),
        // A cube within T of a voxel's centre is within `margin` voxels of the voxel on every
        // axis (its offset k gives a distance of at least (k - 1/2) voxels).
        margin_(static_cast<int>(std::ceil(truncation / grid.resolution())) + 1),
        margin_bricks_((margin_ + kBrick - 1) / kBrick),
        tiles_y_((bricks_.y() + kTile - 1) / kTile),
        count_((bricks_.x() + kTile - 1) / kTile * tiles_y_) {
    // The largest tile's part must be within the exact transform's size.
    esdf_detail::checkTransformable(
        Eigen::Vector3i(kTile * kBrick + 2 * margin_, kTile * kBrick + 2 * margin_, n_.z())
            .cwiseMin(n_),
        "Esdf::truncated (a tile)");
  }

  /// Bricks per axis.
  const Eigen::Vector3i& bricks() const { return bricks_; }
  /// Tiles in all.
  int count() const { return count_; }

  /// Tile t's bricks: sets its entries of `table` (brick x-major, z fastest) that are not +T,
  /// to `deep` for a brick all at -T and into the returned chunk for the others.
  TileBricks build(int t, std::vector<const std::int16_t*>& table, const std::int16_t* deep) const {
    const Eigen::Vector3i first(t / tiles_y_ * kTile, t % tiles_y_ * kTile, 0);
    const Eigen::Vector3i last(std::min(first.x() + kTile, bricks_.x()),
                               std::min(first.y() + kTile, bricks_.y()), bricks_.z());
    int z_low = 0;
    int z_high = 0;
    if (!obstacleHeights(first, last, z_low, z_high)) return {};  // every brick stays at +T
    const Eigen::Vector3i low =
        (Eigen::Vector3i(first.x() * kBrick - margin_, first.y() * kBrick - margin_,
                         z_low * kBrick - margin_))
            .cwiseMax(Eigen::Vector3i::Zero());
    const Eigen::Vector3i high =
        Eigen::Vector3i(last.x() * kBrick + margin_, last.y() * kBrick + margin_,
                        (z_high + 1) * kBrick + margin_)
            .cwiseMin(n_);
    const VoxelGrid part = denseCopy(grid_, low, high);
    std::vector<std::int32_t> field;
    esdf_detail::signedSquaredDistances(part, 1, field, beyond_);
    // The bricks of the tile with a value strictly inside (-T, T); the others share +T or -T.
    std::vector<std::int16_t> values;
    std::vector<std::size_t> owners;
    std::int16_t brick[kBrickVoxels];
    for (int bx = first.x(); bx < last.x(); ++bx) {
      for (int by = first.y(); by < last.y(); ++by) {
        for (int bz = 0; bz < bricks_.z(); ++bz) {
          const Eigen::Vector3i from = Eigen::Vector3i(bx, by, bz) * kBrick;
          if (from.z() + kBrick <= low.z() || from.z() >= high.z()) continue;  // beyond the margin
          const BrickKind kind = fillBrick(part, field, low, high, from, brick);
          const std::size_t index =
              (static_cast<std::size_t>(bx) * bricks_.y() + by) * bricks_.z() + bz;
          if (kind == BrickKind::kDeep) table[index] = deep;
          if (kind != BrickKind::kMixed) continue;
          owners.push_back(index);
          values.insert(values.end(), brick, brick + kBrickVoxels);
        }
      }
    }
    if (owners.empty()) return {};
    TileBricks made{std::make_unique<std::int16_t[]>(values.size()), owners.size()};
    std::copy(values.begin(), values.end(), made.chunk.get());
    // Each tile writes its own entries of the table.
    for (std::size_t k = 0; k < owners.size(); ++k) {
      table[owners[k]] = made.chunk.get() + k * kBrickVoxels;
    }
    return made;
  }

 private:
  static constexpr int kBrick = VoxelGrid::kBrick;
  static constexpr int kBrickVoxels = kBrick * kBrick * kBrick;

  /// A brick's codes: all +T, all -T, or some inside (-T, T).
  enum class BrickKind { kFar, kDeep, kMixed };

  /// The lowest and highest brick heights holding an obstacle within the margin of the tile's
  /// columns of bricks [first, last); false when there is none.
  bool obstacleHeights(const Eigen::Vector3i& first, const Eigen::Vector3i& last, int& z_low,
                       int& z_high) const {
    z_low = bricks_.z();
    z_high = -1;
    for (int bx = std::max(0, first.x() - margin_bricks_);
         bx < std::min(bricks_.x(), last.x() + margin_bricks_); ++bx) {
      for (int by = std::max(0, first.y() - margin_bricks_);
           by < std::min(bricks_.y(), last.y() + margin_bricks_); ++by) {
        for (int bz = 0; bz < bricks_.z(); ++bz) {
          if (!mayHoldObstacle(grid_, bx, by, bz)) continue;
          z_low = std::min(z_low, bz);
          z_high = std::max(z_high, bz);
        }
      }
    }
    return z_high >= 0;
  }

  /// A voxel's code from its entry of the signed field: its squared distance within T,
  /// signed; kBeyond past T.
  std::int16_t code(std::int32_t entry) const {
    const std::int32_t squared = decodeSigned(entry);
    const std::int16_t magnitude = squared < beyond_ ? static_cast<std::int16_t>(squared) : kBeyond;
    return entry < 0 ? static_cast<std::int16_t>(-magnitude) : magnitude;
  }

  /// The codes of the brick whose first voxel is `from` into `brick` (x-major, z fastest), from
  /// the signed `field` of the tile's `part` (the voxels [low, high)).
  BrickKind fillBrick(const VoxelGrid& part, const std::vector<std::int32_t>& field,
                      const Eigen::Vector3i& low, const Eigen::Vector3i& high,
                      const Eigen::Vector3i& from, std::int16_t* brick) const {
    // Voxels past the grid's end are never read (+T keeps such a brick shared), and
    // those below or above the tile's part are more than T from every obstacle.
    const int z_from = std::max(from.z(), low.z());
    const int z_to = std::min(from.z() + kBrick, high.z());
    bool all_far = true;
    bool all_deep = true;
    for (int i = 0; i < kBrick * kBrick; ++i) {
      const int x = from.x() + (i >> 3);
      const int y = from.y() + (i & 7);
      std::int16_t* row = brick + i * kBrick;
      std::fill(row, row + kBrick, kBeyond);
      if (x >= n_.x() || y >= n_.y()) continue;
      const std::size_t start = part.index(x - low.x(), y - low.y(), z_from - low.z());
      for (int z = z_from; z < z_to; ++z) row[z - from.z()] = code(field[start + (z - z_from)]);
      for (int k = 0; k < kBrick; ++k) {
        all_far = all_far && row[k] == kBeyond;
        all_deep = all_deep && row[k] == -kBeyond;
      }
    }
    if (all_deep) return BrickKind::kDeep;
    return all_far ? BrickKind::kFar : BrickKind::kMixed;
  }

  const VoxelGrid& grid_;
  Eigen::Vector3i n_;
  Eigen::Vector3i bricks_;
  std::int32_t beyond_;
  int margin_;
  int margin_bricks_;
  int tiles_y_;
  int count_;
};

}  // namespace

std::shared_ptr<Esdf::Bricks> Esdf::startTruncated(const VoxelGrid& grid, double truncation,
                                                   const char* who) {
  if (grid.size() == 0) throw InvalidArgument(std::string(who) + ": empty grid");
  if (!(truncation > 0.0 && truncation < INFINITY)) {
    throw InvalidArgument(std::string(who) + ": the truncation must be a positive finite distance");
  }
  if (truncation > kMostTruncationVoxels * grid.resolution()) {
    throw InvalidArgument(std::string(who) + ": a truncation of " + std::to_string(truncation) +
                          " m is more than 90 voxels");
  }
  setGeometry(grid);
  truncation_ = truncation;
  auto store = std::make_shared<Bricks>();
  std::fill(std::begin(store->far), std::end(store->far), kBeyond);
  std::fill(std::begin(store->deep), std::end(store->deep), static_cast<std::int16_t>(-kBeyond));
  store->values =
      codeValues(static_cast<float>(0.5 * grid.resolution()), static_cast<float>(truncation));
  const Eigen::Vector3i bricks = (dims_.array() + VoxelGrid::kBrick - 1) / VoxelGrid::kBrick;
  store->table.assign(static_cast<std::size_t>(bricks.cast<double>().prod()), store->far);
  brick_strides_[0] = static_cast<std::size_t>(bricks.y()) * bricks.z();
  brick_strides_[1] = static_cast<std::size_t>(bricks.z());
  return store;
}

void Esdf::finishTruncated(std::shared_ptr<Bricks> store) {
  brick_table_ = store->table.data();
  code_values_ = store->values.data();
  bricks_ = std::move(store);
}

Esdf Esdf::truncated(const VoxelGrid& grid, double truncation, int threads) {
  if (threads < 0) throw InvalidArgument("Esdf::truncated: threads must be >= 0");
  Esdf esdf;
  const std::shared_ptr<Bricks> store = esdf.startTruncated(grid, truncation, "Esdf::truncated");
  threads = esdf_detail::buildThreads(grid, threads, kParallelVoxels);
  const auto limit = static_cast<float>(truncation);
  const auto half_voxel = static_cast<float>(0.5 * grid.resolution());
  const TruncatedTiles tiles(grid, truncation, leastBeyond(half_voxel, limit));
  std::atomic<int> next_tile{0};
  std::mutex chunks_mutex;
  esdf_detail::inParallel(static_cast<std::size_t>(threads), threads,
                          [&](std::size_t, std::size_t) {
                            for (int t = next_tile++; t < tiles.count(); t = next_tile++) {
                              TileBricks made = tiles.build(t, store->table, store->deep);
                              if (made.count == 0) continue;
                              const std::lock_guard<std::mutex> lock(chunks_mutex);
                              store->allocated += made.count;
                              store->chunks.push_back(std::move(made.chunk));
                            }
                          });
  esdf.finishTruncated(store);
  return esdf;
}

Esdf Esdf::fromBricks(const VoxelGrid& grid, double truncation, std::span<const std::int32_t> slots,
                      ValueArray<std::int16_t> codes) {
  Esdf esdf;
  const std::shared_ptr<Bricks> store = esdf.startTruncated(grid, truncation, "Esdf::fromBricks");
  if (slots.size() != store->table.size()) {
    throw InvalidArgument("Esdf::fromBricks: " + std::to_string(slots.size()) + " slots for " +
                          std::to_string(store->table.size()) + " bricks");
  }
  if (codes.size() % kBrickVoxels != 0) {
    throw InvalidArgument("Esdf::fromBricks: the codes are not whole bricks");
  }
  const std::size_t own = codes.size() / kBrickVoxels;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const std::int32_t slot = slots[i];
    if (slot < -2 || (slot >= 0 && static_cast<std::size_t>(slot) >= own)) {
      throw InvalidArgument("Esdf::fromBricks: brick " + std::to_string(i) + " names slot " +
                            std::to_string(slot) + " of " + std::to_string(own));
    }
    store->table[i] = slot == -1   ? store->far
                      : slot == -2 ? store->deep
                                   : codes.data() + static_cast<std::size_t>(slot) * kBrickVoxels;
  }
  store->allocated = own;
  store->stored = std::move(codes);
  esdf.finishTruncated(store);
  return esdf;
}

std::size_t Esdf::brickCount() const { return bricks_ ? bricks_->table.size() : 0; }

const std::int16_t* Esdf::brickCodes(std::size_t index, int& shared) const {
  const std::int16_t* codes = bricks_->table.at(index);
  shared = codes == bricks_->far ? 1 : (codes == bricks_->deep ? -1 : 0);
  return shared == 0 ? codes : nullptr;
}

}  // namespace kinolab
