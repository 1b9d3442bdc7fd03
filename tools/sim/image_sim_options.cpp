#include "tools/sim/image_sim_options.h"

#include <charconv>
#include <cmath>
#include <sstream>

namespace evermap::sim {
namespace {

namespace fs = std::filesystem;

// Prefixes of the keys this file reads; every other key goes to loadSimOptions.
constexpr const char* kOwnPrefixes[] = {"render.",   "world.",    "texture.",
                                        "lighting.", "passerby.", "rgbd."};

bool ownKey(const std::string& key) {
  for (const char* p : kOwnPrefixes) {
    if (key.rfind(p, 0) == 0) return true;
  }
  return false;
}

// The one table of this file's keys, in file order. `encoding` is handled apart (a string).
template <typename Options, typename Visitor>
void visitOwn(Options& o, Visitor&& v) {
  auto& r = o.render;
  v("render.width", &r.width);
  v("render.height", &r.height);
  v("render.rate_hz", &r.rate_hz);
  v("render.noise_sigma_gray", &r.noise_sigma_gray);
  v("render.posters", &r.posters);
  v("render.session", &r.session);
  v("render.max_duration_s", &r.max_duration_s);
  v("render.door_margin_s", &r.door_margin_s);
  auto& w = r.world;
  v("world.ceiling_height_m", &w.ceiling_height_m);
  v("world.grid_cell_m", &w.grid_cell_m);
  v("world.door_width_m", &w.door_width_m);
  v("world.piece_min_m", &w.piece_min_m);
  v("world.piece_max_m", &w.piece_max_m);
  v("world.wall_texel_min_m", &w.wall_texel_min_m);
  v("world.wall_texel_max_m", &w.wall_texel_max_m);
  v("world.floor_texel_m", &w.floor_texel_m);
  v("world.ceiling_texel_m", &w.ceiling_texel_m);
  v("world.poster_probability", &w.poster_probability);
  v("world.poster_width_min_m", &w.poster_width_min_m);
  v("world.poster_width_max_m", &w.poster_width_max_m);
  v("world.dark_light", &w.dark_light);
  v("world.blank_radius_m", &w.blank_radius_m);
  v("world.brightness_jitter", &w.brightness_jitter);
  v("texture.size", &r.textures.size);
  v("texture.variants", &r.textures.variants);
  v("texture.poster_size", &r.textures.poster_size);
  v("texture.max_posters", &r.textures.max_posters);
  auto& d = r.depth;
  v("rgbd.min_range_m", &d.min_range_m);
  v("rgbd.max_range_m", &d.max_range_m);
  v("rgbd.noise_coefficient", &d.noise_coefficient);
  v("rgbd.unit_m", &d.unit_m);
  v("rgbd.edge_jump_fraction", &d.edge_jump_fraction);
  v("rgbd.edge_hole_px", &d.edge_hole_px);
  v("rgbd.shadow_baseline_m", &d.shadow_baseline_m);
  v("rgbd.dropout_fraction", &d.dropout_fraction);
  auto& l = o.lighting;
  v("lighting.gain", &l.base.gain);
  v("lighting.offset_gray", &l.base.offset_gray);
  v("lighting.gamma", &l.base.gamma);
  v("lighting.gain_jitter", &l.gain_jitter);
  v("lighting.offset_jitter_gray", &l.offset_jitter_gray);
  v("lighting.gamma_jitter", &l.gamma_jitter);
  auto& p = o.passerby;
  v("passerby.distance_min_m", &p.distance_min_m);
  v("passerby.distance_max_m", &p.distance_max_m);
  v("passerby.width_m", &p.width_m);
  v("passerby.height_m", &p.height_m);
}

std::string format(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}
std::string format(int v) { return std::to_string(v); }
std::string format(const std::string& v) { return v; }

}  // namespace

Status RenderSimOptions::validate() const {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    return makeError("render.width: image size must be in [16, 8192], got ", width, "x", height);
  }
  if (!(rate_hz > 0.0 && rate_hz <= 1000.0))
    return makeError("render.rate_hz: must be in (0, 1000]");
  if (!(noise_sigma_gray >= 0.0 && noise_sigma_gray < 100.0)) {
    return makeError("render.noise_sigma_gray: must be in [0, 100)");
  }
  if (posters.empty()) return makeError("render.posters: 'auto', 'none' or a folder");
  if (session < 0) return makeError("render.session: must be >= 0");
  if (!(max_duration_s >= 0.0)) return makeError("render.max_duration_s: must be >= 0");
  if (!(door_margin_s >= 0.0)) return makeError("render.door_margin_s: must be >= 0");
  if (Status s = world.validate(); !s) return makeError("world.", s.error().message);
  if (Status s = textures.validate(); !s) return makeError("texture.", s.error().message);
  if (Status s = depth.validate(); !s) return makeError("rgbd.", s.error().message);
  return Ok{};
}

Status LightingOptions::validate() const {
  if (Status s = base.validate(); !s) return makeError("lighting.", s.error().message);
  if (!(gain_jitter >= 0.0 && gain_jitter < 1.0))
    return makeError("lighting.gain_jitter: must be in [0, 1)");
  if (!(gamma_jitter >= 0.0 && gamma_jitter < 1.0))
    return makeError("lighting.gamma_jitter: must be in [0, 1)");
  if (!(offset_jitter_gray >= 0.0 && offset_jitter_gray < 128.0)) {
    return makeError("lighting.offset_jitter_gray: must be in [0, 128)");
  }
  return Ok{};
}

Lighting LightingOptions::forSession(int session, uint64_t seed) const {
  if (session == 0) return base;
  Random rng = Random::derive(seed, 10300 + static_cast<uint64_t>(session));
  Lighting l = base;
  l.gain *= 1.0 + gain_jitter * rng.uniform(-1.0, 1.0);
  l.offset_gray += offset_jitter_gray * rng.uniform(-1.0, 1.0);
  l.gamma *= 1.0 + gamma_jitter * rng.uniform(-1.0, 1.0);
  return l;
}

Status PasserbyOptions::validate() const {
  if (!(distance_min_m > 0.05 && distance_max_m >= distance_min_m)) {
    return makeError("passerby.distance_min_m: need 0.05 < min <= max");
  }
  if (!(width_m > 0.0 && height_m > 0.0)) return makeError("passerby.width_m: size must be > 0");
  return Ok{};
}

PinholeCamera ImageSimOptions::camera() const {
  const CameraOptions& c = sim.sensors.camera;
  return PinholeCamera{render.width, render.height, c.fx, c.fy, c.cx, c.cy};
}

Status ImageSimOptions::validate() const {
  if (sim.mode != SimOptions::Mode::kBuilding) {
    return makeError("mode: the image-level simulator needs mode = building");
  }
  if (Status s = render.validate(); !s) return s;
  if (Status s = camera().validate(); !s) return makeError("camera.", s.error().message);
  if (Status s = lighting.validate(); !s) return s;
  if (Status s = passerby.validate(); !s) return s;
  if (render.session >= sim.patrol.sessions) {
    return makeError("render.session: must be < patrol.sessions (", sim.patrol.sessions, ")");
  }
  return Ok{};
}

fs::path ImageSimOptions::posterFolder() const {
  if (render.posters == "none") return {};
  if (render.posters == "auto")
    return defaultPosterFolder(config_folder / ".." / ".." / "shared" / "data");
  const fs::path p(render.posters);
  return p.is_relative() ? (config_folder / p).lexically_normal() : p;
}

std::string ImageSimOptions::toConfigText() const {
  std::ostringstream out;
  out << sim.toConfigText();
  out << "render.encoding = " << messages::toString(render.encoding) << "\n";
  out << "render.camera = " << (render.camera == CameraMode::kRgbd ? "rgbd" : "stereo") << "\n";
  ImageSimOptions copy = *this;
  visitOwn(copy,
           [&](const char* key, auto* field) { out << key << " = " << format(*field) << "\n"; });
  return out.str();
}

Expected<ImageSimOptions> loadImageSimOptions(const KeyValueFile& file) {
  auto own = KeyValueFile::parse("", file.name());
  auto rest = KeyValueFile::parse("", file.name());
  if (!own || !rest) return makeError(file.name(), ": cannot split the configuration");
  for (const KeyValueFile::Entry& e : file.entries()) {
    KeyValueFile& target = ownKey(e.key) ? *own : *rest;
    if (Status s = target.set(e.key + " = " + e.value, e.origin); !s) return s.error();
  }
  ImageSimOptions o;
  o.config_folder = file.folder();
  auto sim = loadSimOptions(*rest);
  if (!sim) return sim.error();
  o.sim = std::move(*sim);
  KeyValueReader reader(*own);
  std::string encoding = "png";
  reader.read("render.encoding", &encoding);
  if (encoding == "gray8") {
    o.render.encoding = messages::ImageEncoding::kGray8;
  } else if (encoding != "png") {
    return makeError(reader.where("render.encoding"),
                     ": render.encoding: expected 'png' or 'gray8', got '", encoding, "'");
  }
  std::string camera = "stereo";
  reader.read("render.camera", &camera);
  if (camera == "rgbd") {
    o.render.camera = CameraMode::kRgbd;
  } else if (camera != "stereo") {
    return makeError(reader.where("render.camera"),
                     ": render.camera: expected 'stereo' or 'rgbd', got '", camera, "'");
  }
  visitOwn(o, [&](const char* key, auto* field) { reader.read(key, field); });
  if (Status s = reader.finish(); !s) return s.error();
  if (Status s = o.validate(); !s) {
    const std::string& m = s.error().message;
    const std::string key = m.substr(0, m.find(':'));
    const KeyValueFile::Entry* e = file.find(key);
    return makeError(e ? e->origin : file.name() + " (default value)", ": ", m);
  }
  return o;
}

}  // namespace evermap::sim
