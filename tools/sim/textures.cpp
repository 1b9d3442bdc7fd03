#include "tools/sim/textures.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <numbers>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace evermap::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// A size x size float canvas that wraps around (every pattern below is seamless).
struct Canvas {
  int n;
  std::vector<float> v;
  explicit Canvas(int size, float fill = 0.0f)
      : n(size), v(static_cast<size_t>(size) * size, fill) {}
  float& at(int x, int y) {
    return v[static_cast<size_t>(((y % n) + n) % n) * n + ((x % n) + n) % n];
  }
  void fillRect(int x0, int y0, int w, int h, float value) {
    for (int y = y0; y < y0 + h; ++y) {
      for (int x = x0; x < x0 + w; ++x) at(x, y) = value;
    }
  }
  void addNoise(float amplitude, Random& rng) {
    for (float& x : v) x += amplitude * static_cast<float>(rng.normal());
  }
  std::vector<uint8_t> toGray() const {
    std::vector<uint8_t> out(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      out[i] = static_cast<uint8_t>(std::clamp(std::lround(v[i]), 0L, 255L));
    }
    return out;
  }
};

// Periodic value noise: random values on a lattice of `cells` x `cells` over the canvas,
// interpolated with the smoothstep weight; `cells` divides n, so it tiles.
void addValueNoise(Canvas* c, int cells, float amplitude, Random& rng) {
  std::vector<float> lattice(static_cast<size_t>(cells) * cells);
  for (float& x : lattice) x = static_cast<float>(rng.uniform(-1.0, 1.0));
  const float step = static_cast<float>(c->n) / static_cast<float>(cells);
  for (int y = 0; y < c->n; ++y) {
    const float gy = static_cast<float>(y) / step;
    const int y0 = static_cast<int>(gy);
    float fy = gy - static_cast<float>(y0);
    fy = fy * fy * (3.0f - 2.0f * fy);
    for (int x = 0; x < c->n; ++x) {
      const float gx = static_cast<float>(x) / step;
      const int x0 = static_cast<int>(gx);
      float fx = gx - static_cast<float>(x0);
      fx = fx * fx * (3.0f - 2.0f * fx);
      auto l = [&](int i, int j) {
        return lattice[static_cast<size_t>(j % cells) * cells + i % cells];
      };
      const float top = l(x0, y0) + fx * (l(x0 + 1, y0) - l(x0, y0));
      const float bottom = l(x0, y0 + 1) + fx * (l(x0 + 1, y0 + 1) - l(x0, y0 + 1));
      c->at(x, y) += amplitude * (top + fy * (bottom - top));
    }
  }
}

// Fractal sum of value noise from `first_cells` lattice cells, halving the amplitude per octave.
void addFbm(Canvas* c, int first_cells, float amplitude, Random& rng) {
  for (int cells = first_cells; cells <= c->n / 2; cells *= 2, amplitude *= 0.55f) {
    addValueNoise(c, cells, amplitude, rng);
  }
}

void stretch(Canvas* c, float lo, float hi) {
  const auto [mn, mx] = std::minmax_element(c->v.begin(), c->v.end());
  const float a = *mn, b = *mx;
  if (b - a < 1e-6f) return;
  for (float& x : c->v) x = lo + (hi - lo) * (x - a) / (b - a);
}

Canvas noise(int n, Random& rng) {
  Canvas c(n);
  addFbm(&c, 4, 1.0f, rng);
  stretch(&c, 15.0f, 240.0f);
  c.addNoise(3.0f, rng);
  return c;
}

Canvas bricks(int n, Random& rng) {
  Canvas c(n, 200.0f);  // mortar
  const int rows = 8, cols = 4;
  const int bh = n / rows, bw = n / cols, mortar = std::max(2, n / 96);
  for (int r = 0; r < rows; ++r) {
    const int shift = (r % 2) * bw / 2;
    for (int k = 0; k < cols; ++k) {
      const float shade = static_cast<float>(rng.uniform(50.0, 170.0));
      c.fillRect(k * bw + shift + mortar, r * bh + mortar, bw - mortar, bh - mortar, shade);
    }
  }
  addFbm(&c, 16, 18.0f, rng);
  c.addNoise(6.0f, rng);
  return c;
}

Canvas tiles(int n, Random& rng) {
  Canvas c(n, 60.0f);  // grout
  const int count = 8, t = n / count, grout = std::max(1, n / 128);
  for (int j = 0; j < count; ++j) {
    for (int i = 0; i < count; ++i) {
      c.fillRect(i * t + grout, j * t + grout, t - grout, t - grout,
                 static_cast<float>(rng.uniform(110.0, 230.0)));
      if (rng.bernoulli(0.3)) {  // a fleck on some tiles
        const int s = t / 4;
        c.fillRect(i * t + static_cast<int>(rng.index(t - s)),
                   j * t + static_cast<int>(rng.index(t - s)), s, s,
                   static_cast<float>(rng.uniform(40.0, 120.0)));
      }
    }
  }
  c.addNoise(5.0f, rng);
  return c;
}

Canvas wood(int n, Random& rng) {
  Canvas warp(n);
  addFbm(&warp, 4, 1.0f, rng);
  Canvas c(n);
  const int planks = 8, ph = n / planks;
  for (int p = 0; p < planks; ++p) {
    const double rings = static_cast<double>(rng.integer(3, 9));  // integer: periodic along u
    const double phase = rng.uniform(0.0, kTwoPi);
    const double base = rng.uniform(90.0, 160.0);
    for (int y = p * ph; y < (p + 1) * ph; ++y) {
      for (int x = 0; x < n; ++x) {
        const double s = kTwoPi * rings * x / n + phase + 3.0 * warp.at(x, y) + 0.15 * (y - p * ph);
        c.at(x, y) = static_cast<float>(base + 45.0 * std::sin(s) * std::sin(0.5 * s + 1.0));
      }
    }
    for (int x = 0; x < n; ++x) c.at(x, p * ph) = 30.0f;  // the gap between planks
    const int joint = static_cast<int>(rng.index(n));
    for (int y = p * ph; y < (p + 1) * ph; ++y) c.at(joint, y) = 30.0f;
  }
  c.addNoise(4.0f, rng);
  return c;
}

Canvas terrazzo(int n, Random& rng) {
  Canvas c(n);
  addFbm(&c, 4, 20.0f, rng);
  for (float& x : c.v) x += 150.0f;
  const int dots = n * n / 90;
  for (int k = 0; k < dots; ++k) {
    const int cx = static_cast<int>(rng.index(n)), cy = static_cast<int>(rng.index(n));
    const double r = rng.uniform(1.0, 4.5);
    const float shade = static_cast<float>(rng.bernoulli(0.5) ? rng.uniform(10.0, 90.0)
                                                              : rng.uniform(200.0, 255.0));
    const int ri = static_cast<int>(std::ceil(r));
    for (int dy = -ri; dy <= ri; ++dy) {
      for (int dx = -ri; dx <= ri; ++dx) {
        if (dx * dx + dy * dy <= r * r) c.at(cx + dx, cy + dy) = shade;
      }
    }
  }
  c.addNoise(4.0f, rng);
  return c;
}

Canvas blocks(int n, Random& rng) {
  Canvas c(n, static_cast<float>(rng.uniform(100.0, 180.0)));
  const int count = 45;
  for (int k = 0; k < count; ++k) {
    const int w = static_cast<int>(rng.integer(n / 16, n / 3)),
              h = static_cast<int>(rng.integer(n / 16, n / 3));
    const int x = static_cast<int>(rng.index(n)), y = static_cast<int>(rng.index(n));
    c.fillRect(x - 2, y - 2, w + 4, h + 4, 25.0f);
    c.fillRect(x, y, w, h, static_cast<float>(rng.uniform(40.0, 240.0)));
  }
  addFbm(&c, 8, 10.0f, rng);
  c.addNoise(4.0f, rng);
  return c;
}

Canvas text(int n, Random& rng) {
  Canvas c(n, static_cast<float>(rng.uniform(190.0, 235.0)));
  const int line = std::max(8, n / 20);
  for (int y = line / 2; y + line <= n; y += line) {
    int x = static_cast<int>(rng.index(8));
    while (x < n) {
      const int w = static_cast<int>(rng.integer(3, 22));
      const int h = static_cast<int>(rng.integer(line / 2, line - 2));
      if (rng.bernoulli(0.85))
        c.fillRect(x, y + line - 2 - h, w, h, static_cast<float>(rng.uniform(10.0, 80.0)));
      x += w + static_cast<int>(rng.integer(3, 10));
    }
  }
  c.addNoise(5.0f, rng);
  return c;
}

Canvas brushed(int n, Random& rng) {
  Canvas c(n);
  std::vector<float> row(static_cast<size_t>(n));
  for (float& x : row) x = static_cast<float>(rng.uniform(-30.0, 30.0));
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) c.at(x, y) = 150.0f + row[static_cast<size_t>(y)];
  }
  addFbm(&c, 4, 25.0f, rng);
  // Panel seams and rivets: corners on an otherwise smooth surface.
  for (int k = 0; k < n; ++k) c.at(k, 0) = c.at(0, k) = 40.0f;
  for (int y = n / 8; y < n; y += n / 4) {
    for (int x = n / 8; x < n; x += n / 4) c.fillRect(x - 2, y - 2, 4, 4, 230.0f);
  }
  c.addNoise(3.0f, rng);
  return c;
}

bool isPowerOfTwo(int n) { return n >= 4 && (n & (n - 1)) == 0; }

// Each pattern's name and generator, in the order of enum Pattern.
struct PatternMaker {
  const char* name;
  Canvas (*make)(int n, Random& rng);
};
constexpr PatternMaker kPatterns[kPatternCount] = {
    {"noise", noise},       {"bricks", bricks}, {"tiles", tiles}, {"wood", wood},
    {"terrazzo", terrazzo}, {"blocks", blocks}, {"text", text},   {"brushed", brushed}};

}  // namespace

Texture::Texture(int size, std::vector<uint8_t> base) : size_(size) {
  if (!isPowerOfTwo(size) || base.size() != static_cast<size_t>(size) * size) std::abort();
  levels_.push_back(std::move(base));
  for (int s = size / 2; s >= 1; s /= 2) {
    const std::vector<uint8_t>& prev = levels_.back();
    const int ps = 2 * s;
    std::vector<uint8_t> next(static_cast<size_t>(s) * s);
    for (int y = 0; y < s; ++y) {
      for (int x = 0; x < s; ++x) {
        const size_t i = static_cast<size_t>(2 * y) * ps + 2 * x;
        next[static_cast<size_t>(y) * s + x] =
            static_cast<uint8_t>((prev[i] + prev[i + 1] + prev[i + ps] + prev[i + ps + 1] + 2) / 4);
      }
    }
    levels_.push_back(std::move(next));
  }
  for (std::vector<uint8_t>& level : levels_) level.resize(level.size() + kGatherPadBytes, 0);
  makeViews();
}

void Texture::makeViews() {
  view_.clear();
  for (size_t l = 0; l < levels_.size(); ++l) {
    const int side = size_ >> l;
    view_.push_back(Level{levels_[l].data(), side - 1,
                          std::countr_zero(static_cast<unsigned>(side)),
                          256.0f / static_cast<float>(1 << l)});
  }
  last_ = static_cast<int>(view_.size()) - 1;
}

const char* patternName(Pattern p) {
  const auto i = static_cast<size_t>(p);
  return i < std::size(kPatterns) ? kPatterns[i].name : "?";
}

Texture makePattern(Pattern pattern, int size, Random& rng) {
  const Canvas c = kPatterns[static_cast<size_t>(pattern)].make(size, rng);
  return Texture(size, c.toGray());
}

Texture makeBlank(int size, int mean, double contrast, Random& rng) {
  Canvas c(size);
  addValueNoise(&c, 2, static_cast<float>(contrast), rng);
  for (float& x : c.v) x += static_cast<float>(mean);
  return Texture(size, c.toGray());
}

Status TextureOptions::validate() const {
  if (!isPowerOfTwo(size))
    return makeError("texture_size: must be a power of two >= 4, got ", size);
  if (!isPowerOfTwo(poster_size))
    return makeError("poster_size: must be a power of two >= 4, got ", poster_size);
  if (variants < 1) return makeError("texture_variants: must be >= 1, got ", variants);
  if (max_posters < 0) return makeError("max_posters: must be >= 0, got ", max_posters);
  return Ok{};
}

Expected<TextureLibrary> makeTextureLibrary(
    const TextureOptions& o, const fs::path& poster_folder, Random& rng,
    const std::function<void(int made, int total)>& on_made) {
  if (Status s = o.validate(); !s) return s.error();
  TextureLibrary lib;
  const int procedural = 7 * o.variants + 2;
  auto add = [&](Texture t, std::vector<int>* a, std::vector<int>* b = nullptr) {
    lib.textures.push_back(std::move(t));
    const int id = static_cast<int>(lib.textures.size()) - 1;
    if (a) a->push_back(id);
    if (b) b->push_back(id);
    if (on_made && id < procedural) on_made(id + 1, procedural);
    return id;
  };
  for (int k = 0; k < o.variants; ++k) {
    add(makePattern(Pattern::kNoise, o.size, rng), &lib.wall, &lib.people);
    add(makePattern(Pattern::kBricks, o.size, rng), &lib.wall);
    add(makePattern(Pattern::kTiles, o.size, rng), &lib.floor, &lib.wall);
    add(makePattern(Pattern::kWood, o.size, rng), &lib.floor, &lib.wall);
    add(makePattern(Pattern::kTerrazzo, o.size, rng), &lib.floor, &lib.ceiling);
    add(makePattern(Pattern::kBlocks, o.size, rng), &lib.wall, &lib.people);
    add(makePattern(Pattern::kText, o.size, rng), &lib.wall);
  }
  lib.cab = add(makePattern(Pattern::kBrushed, o.size, rng), nullptr);
  lib.blank = add(makeBlank(o.size, 170, 6.0, rng), nullptr);
  if (!poster_folder.empty()) {
    if (!fs::is_directory(poster_folder)) {
      return makeError(poster_folder.string(), ": poster folder does not exist");
    }
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(poster_folder)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".jpg" || ext == ".png" || ext == ".jpeg") files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      if (static_cast<int>(lib.posters.size()) >= o.max_posters) break;
      cv::Mat gray = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
      if (gray.empty()) return makeError(f.string(), ": not a readable image");
      cv::Mat square;
      cv::resize(gray, square, cv::Size(o.poster_size, o.poster_size), 0, 0, cv::INTER_AREA);
      add(Texture(o.poster_size, std::vector<uint8_t>(square.datastart, square.dataend)),
          &lib.posters);
    }
    if (lib.posters.empty()) return makeError(poster_folder.string(), ": no .jpg or .png image");
  } else {
    // Procedural stand-ins for photographs: blocks and text, like notice boards.
    for (int k = 0; k < 6; ++k) {
      add(makePattern(k % 2 ? Pattern::kText : Pattern::kBlocks, o.poster_size, rng), &lib.posters);
    }
  }
  return lib;
}

fs::path defaultPosterFolder(const fs::path& default_root) {
  fs::path root = default_root;
  if (const char* env = std::getenv("EVERMAP_DATA"); env && *env) root = env;
  const fs::path folder = root / "rtabmap-lcd-samples" / "samples";
  return fs::is_directory(folder) ? folder : fs::path();
}

}  // namespace evermap::sim
