#pragma once
// Gray 8-bit textures for the image-level simulator: procedural patterns (noise, bricks, tiles,
// wood, terrazzo, blocks, stripes of text) and photographs used as posters, each with a mip
// pyramid so distant and grazing surfaces are sampled from a pre-filtered level instead of
// aliasing (Williams 1983, "Pyramidal parametrics").
//
// Procedural textures are square, power-of-two sized and seamless (they repeat with period
// size() in both directions): a long wall tiles them. Posters are sampled inside their own
// rectangle only, so their aspect is free; they are stored square (resampled) and the poster
// rectangle on the wall restores the photograph's aspect.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "core/common/expected.h"
#include "tools/sim/random.h"

namespace evermap::sim {

// Byte arrays read by 32-bit gathers (render_kernels.h: a gather of byte i reads bytes i..i+3)
// end with this many spare bytes.
inline constexpr int kGatherPadBytes = 3;

class Texture {
 public:
  struct Level {
    const uint8_t* texels;  // the level's texels
    int mask;               // side - 1
    int shift;              // log2(side)
    float scale;            // 256 / 2^l: level-0 texels to level-l fixed point
  };

  // `base` is size x size gray levels, row-major; size a power of two >= 4.
  Texture(int size, std::vector<uint8_t> base);

  int size() const { return size_; }
  int levels() const { return static_cast<int>(levels_.size()); }
  const uint8_t* level(int l) const { return levels_[l].data(); }
  // Mip level `level`, clamped to the pyramid.
  const Level& levelView(int level) const {
    return view_[static_cast<size_t>(level < 0 ? 0 : (level > last_ ? last_ : level))];
  }
  // Bilinear sample at texel coordinates (u, v) of level 0 (texel centres at integer + 0.5),
  // from mip level `level` (clamped to the pyramid), wrapping around the edges. Gray 0..255.
  int sample(float u, float v, int level) const {
    const Level& L = levelView(level);
    // Fixed point, 8 fractional bits; the offset keeps the value positive before the shift.
    const int32_t fu = static_cast<int32_t>(u * L.scale - 128.0f) + (1 << 28);
    const int32_t fv = static_cast<int32_t>(v * L.scale - 128.0f) + (1 << 28);
    const int x0 = (fu >> 8) & L.mask, y0 = (fv >> 8) & L.mask;
    const int x1 = (x0 + 1) & L.mask, y1 = (y0 + 1) & L.mask;
    const int ax = fu & 255, ay = fv & 255;
    const uint8_t* r0 = L.texels + (y0 << L.shift);
    const uint8_t* r1 = L.texels + (y1 << L.shift);
    const int top = r0[x0] * 256 + (r0[x1] - r0[x0]) * ax;
    const int bottom = r1[x0] * 256 + (r1[x1] - r1[x0]) * ax;
    return (top * 256 + (bottom - top) * ay + (1 << 15)) >> 16;
  }

  // Samples along one texture column u at one level (a wall seen by a level camera): the
  // horizontal interpolation is done once. Same values as sample(u, v, level).
  class Column {
   public:
    Column(const Texture& t, float u, int level) {
      L_ = t.view_[static_cast<size_t>(level < 0 ? 0 : (level > t.last_ ? t.last_ : level))];
      const int32_t fu = static_cast<int32_t>(u * L_.scale - 128.0f) + (1 << 28);
      x0_ = (fu >> 8) & L_.mask;
      x1_ = (x0_ + 1) & L_.mask;
      ax_ = fu & 255;
    }
    int operator()(float v) const {
      const int32_t fv = static_cast<int32_t>(v * L_.scale - 128.0f) + (1 << 28);
      const int y0 = (fv >> 8) & L_.mask, y1 = (y0 + 1) & L_.mask, ay = fv & 255;
      const uint8_t* r0 = L_.texels + (y0 << L_.shift);
      const uint8_t* r1 = L_.texels + (y1 << L_.shift);
      const int top = r0[x0_] * 256 + (r0[x1_] - r0[x0_]) * ax_;
      const int bottom = r1[x0_] * 256 + (r1[x1_] - r1[x0_]) * ax_;
      return (top * 256 + (bottom - top) * ay + (1 << 15)) >> 16;
    }

    const Level& level() const { return L_; }
    int x0() const { return x0_; }  // the two texel columns interpolated, and the weight of x1
    int x1() const { return x1_; }
    int ax() const { return ax_; }

   private:
    Level L_;
    int x0_, x1_, ax_;
  };

  Texture(const Texture& other) : size_(other.size_), levels_(other.levels_) { makeViews(); }
  Texture(Texture&& other) noexcept : size_(other.size_), levels_(std::move(other.levels_)) {
    makeViews();
  }
  Texture& operator=(const Texture& other) {
    size_ = other.size_;
    levels_ = other.levels_;
    makeViews();
    return *this;
  }
  Texture& operator=(Texture&& other) noexcept {
    size_ = other.size_;
    levels_ = std::move(other.levels_);
    makeViews();
    return *this;
  }

 private:
  int size_;
  void makeViews();
  std::vector<std::vector<uint8_t>> levels_;  // levels_[l] is (size >> l)^2 + kGatherPadBytes
  std::vector<Level> view_;
  int last_ = 0;
};

enum class Pattern { kNoise, kBricks, kTiles, kWood, kTerrazzo, kBlocks, kText, kBrushed };
const char* patternName(Pattern p);
inline constexpr int kPatternCount = 8;

// A seamless procedural texture of size x size texels.
Texture makePattern(Pattern pattern, int size, Random& rng);

// A smooth, nearly uniform texture (a featureless wall: low-frequency shading only, amplitude
// `contrast` gray levels around `mean`).
Texture makeBlank(int size, int mean, double contrast, Random& rng);

// The textures a world is painted with: procedural ones, then posters.
struct TextureLibrary {
  std::vector<Texture> textures;
  std::vector<int> wall;     // indices of textures suited to walls
  std::vector<int> floor;    // ... to floors
  std::vector<int> ceiling;  // ... to ceilings
  std::vector<int> posters;  // photographs
  std::vector<int> people;   // passers-by (clothes-like patterns)
  int blank = -1;            // the featureless texture
  int cab = -1;              // elevator cab walls
};

struct TextureOptions {
  int size = 256;         // texels per side of procedural textures (power of two)
  int variants = 3;       // procedural textures drawn per pattern
  int poster_size = 256;  // texels per side of a stored poster
  int max_posters = 40;   // photographs loaded at most
  Status validate() const;
};

// Procedural textures from `rng`, plus up to max_posters photographs (*.jpg, *.png, any size,
// converted to gray) from `poster_folder` when it is not empty. A folder that does not exist
// or holds no readable image is an error naming it; callers fall back to procedural posters
// by passing an empty folder. `on_made` (if set) hears of each procedural texture made: how
// many so far, of how many (making them takes seconds).
Expected<TextureLibrary> makeTextureLibrary(
    const TextureOptions& options, const std::filesystem::path& poster_folder, Random& rng,
    const std::function<void(int made, int total)>& on_made = {});

// The folder of photographs used as posters: $EVERMAP_DATA (else `default_root`) joined with
// rtabmap-lcd-samples/samples; empty when it does not exist.
std::filesystem::path defaultPosterFolder(const std::filesystem::path& default_root);

}  // namespace evermap::sim
