#include "tools/sim/image_sim_options.h"

#include <cmath>

#include "core/common/option_fields.h"

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

void declareRender(OptionList& o, RenderSimOptions& r) {
  o.choice("render.encoding", &r.encoding, messages::imageEncodingNames(),
           "how images are stored in the log: zstd rows (decode fastest), png (other tools read "
           "it) or gray8 (raw)");
  o.choice("render.camera", &r.camera,
           {{"stereo", CameraMode::kStereo}, {"rgbd", CameraMode::kRgbd}},
           "a rectified stereo pair (camera.*) or an RGB-D camera (rgbd.*)");
  o.add("render.width", &r.width, "px", "image width (camera.cx inside)").in(16, 8192);
  o.add("render.height", &r.height, "px", "image height (camera.cy inside)").in(16, 8192);
  o.add("render.rate_hz", &r.rate_hz, "Hz", "stereo pairs per second").above(0).max(1000);
  o.add("render.noise_sigma_gray", &r.noise_sigma_gray, "gray", "sensor noise").min(0).below(100);
  o.add("render.posters", &r.posters, "",
        "auto ($EVERMAP_DATA or ../shared/data), none, or a folder of images");
  o.add("render.session", &r.session, "", "the session of the patrol plan rendered").min(0);
  o.add("render.max_duration_s", &r.max_duration_s, "s", "render at most this much (0: all)")
      .min(0);
  o.add("render.door_margin_s", &r.door_margin_s, "s",
        "the cab door is closed from this long before a ride to after")
      .min(0);
}

void declareWorld(OptionList& o, WorldOptions& w) {
  o.add("world.ceiling_height_m", &w.ceiling_height_m, "m", "above each floor surface").above(0.5);
  o.add("world.grid_cell_m", &w.grid_cell_m, "m", "rasterisation of the regions").above(0).max(0.5);
  o.add("world.door_width_m", &w.door_width_m, "m", "room doors and the elevator door").positive();
  o.add("world.piece_min_m", &w.piece_min_m, "m", "walls are cut into pieces this long at least")
      .positive();
  o.add("world.piece_max_m", &w.piece_max_m, "m", "... at most (>= min)").any();
  o.add("world.wall_texel_min_m", &w.wall_texel_min_m, "m", "wall texel size, least (per piece)")
      .positive();
  o.add("world.wall_texel_max_m", &w.wall_texel_max_m, "m", "... most (>= min)").any();
  o.add("world.floor_texel_m", &w.floor_texel_m, "m", "floor texel size").positive();
  o.add("world.ceiling_texel_m", &w.ceiling_texel_m, "m", "ceiling texel size").positive();
  o.add("world.poster_probability", &w.poster_probability, "",
        "a poster on a wall piece at least 1.5 m long")
      .in(0, 1);
  o.add("world.poster_width_min_m", &w.poster_width_min_m, "m", "poster width, least").positive();
  o.add("world.poster_width_max_m", &w.poster_width_max_m, "m", "... most (>= min)").any();
  o.add("world.dark_light", &w.dark_light, "", "light level of a dark room (lit: 1)").in(0, 1);
  o.add("world.blank_radius_m", &w.blank_radius_m, "m",
        "featureless zone around a blank-wall junction")
      .min(0);
  o.add("world.brightness_jitter", &w.brightness_jitter, "", "each wall piece is lit 1 +- this")
      .min(0)
      .below(1);
}

void declareTexturesAndDepth(OptionList& o, RenderSimOptions& r) {
  auto& t = r.textures;
  o.add("texture.size", &t.size, "texel", "side of procedural textures (power of two)").min(4);
  o.add("texture.variants", &t.variants, "", "procedural textures drawn per pattern").min(1);
  o.add("texture.poster_size", &t.poster_size, "texel", "side of a stored poster (power of two)")
      .min(4);
  o.add("texture.max_posters", &t.max_posters, "", "photographs loaded at most").min(0);
  auto& d = r.depth;
  o.add("rgbd.min_range_m", &d.min_range_m, "m", "nearer: no depth").min(0);
  o.add("rgbd.max_range_m", &d.max_range_m, "m", "farther: no depth").above(0).max(100);
  o.add("rgbd.noise_coefficient", &d.noise_coefficient, "1/m", "depth noise sigma_z = k z^2")
      .min(0)
      .below(0.1);
  o.add("rgbd.unit_m", &d.unit_m, "m", "metres per depth unit (max_range_m / unit_m < 65535)")
      .above(0)
      .max(0.1);
  o.add("rgbd.edge_jump_fraction", &d.edge_jump_fraction, "",
        "neighbours differing by more than this: a depth edge")
      .above(0)
      .max(10);
  o.add("rgbd.edge_hole_px", &d.edge_hole_px, "px", "holes this far from a depth edge").in(0, 16);
  o.add("rgbd.shadow_baseline_m", &d.shadow_baseline_m, "m", "projector to IR camera (0: none)")
      .in(0, 1);
  o.add("rgbd.dropout_fraction", &d.dropout_fraction, "", "pixels dropped at random")
      .min(0)
      .below(1);
}

void declareLightingAndPasserby(OptionList& o, LightingOptions& l, PasserbyOptions& p) {
  o.add("lighting.gain", &l.base.gain, "", "camera response gain, session 0").above(0).below(10);
  o.add("lighting.offset_gray", &l.base.offset_gray, "gray", "response offset, session 0")
      .above(-255)
      .below(255);
  o.add("lighting.gamma", &l.base.gamma, "", "response gamma, session 0").above(0.1).below(10);
  o.add("lighting.gain_jitter", &l.gain_jitter, "", "per session: gain * (1 + jitter x)")
      .min(0)
      .below(1);
  o.add("lighting.offset_jitter_gray", &l.offset_jitter_gray, "gray",
        "per session: offset + jitter x")
      .min(0)
      .below(128);
  o.add("lighting.gamma_jitter", &l.gamma_jitter, "", "per session: gamma * (1 + jitter x)")
      .min(0)
      .below(1);
  o.add("passerby.distance_min_m", &p.distance_min_m, "m",
        "a passer-by walks this far ahead, least")
      .above(0.05);
  o.add("passerby.distance_max_m", &p.distance_max_m, "m", "... most (>= min)").any();
  o.add("passerby.width_m", &p.width_m, "m", "a passer-by's width").positive();
  o.add("passerby.height_m", &p.height_m, "m", "a passer-by's height").positive();
}

// This simulator's own keys (render.*, world.*, texture.*, rgbd.*, lighting.*, passerby.*).
void declareOwn(OptionList& o, ImageSimOptions& s) {
  declareRender(o, s.render);
  declareWorld(o, s.render.world);
  declareTexturesAndDepth(o, s.render);
  declareLightingAndPasserby(o, s.lighting, s.passerby);
}

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

void ImageSimOptions::declareOptions(OptionList& o) {
  o.nest("", &sim);
  declareOwn(o, *this);
}

std::string ImageSimOptions::toConfigText() const {
  ImageSimOptions copy = *this;
  return OptionList::of(&copy).print();
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
  OptionList list;
  declareOwn(list, o);
  if (Status s = list.load(*own); !s) return s.error();
  if (Status s = o.validate(); !s) {
    const std::string& m = s.error().message;
    return makeError(whereIn(file, m.substr(0, m.find(':'))), ": ", m);
  }
  return o;
}

}  // namespace evermap::sim
