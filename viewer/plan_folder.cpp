#include "viewer/plan_folder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "core/common/option_fields.h"
#include "viewer/json_writer.h"
#include "viewer/web_server.h"

namespace evermap::viewer {

namespace fs = std::filesystem;

namespace {

constexpr int64_t kMaxCells = 64LL * 1024 * 1024;  // 400 m x 400 m at 5 cm

Expected<std::string> readWhole(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return makeError(p.string(), ": cannot be read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// map_server's YAML keys, "key: value" lines (what evermap-map-export and map_saver write).
Expected<std::map<std::string, std::string>> yamlKeys(const fs::path& yaml) {
  auto text = readWhole(yaml);
  if (!text) return text.error();
  std::map<std::string, std::string> keys;
  std::istringstream lines(*text);
  std::string line;
  while (std::getline(lines, line)) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const auto trim = [](std::string s) {
      const auto a = s.find_first_not_of(" \t\r\"'");
      const auto b = s.find_last_not_of(" \t\r\"'");
      return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
    };
    keys[trim(line.substr(0, colon))] = trim(line.substr(colon + 1));
  }
  for (const char* k : {"image", "resolution", "origin", "occupied_thresh", "free_thresh"})
    if (!keys.count(k)) return makeError(yaml.string(), ": no ", k);
  return keys;
}

Expected<double> number(const fs::path& yaml, const std::string& key, const std::string& text) {
  double v = 0.0;
  if (Status s = option_text::parseDouble(text, &v); !s)
    return makeError(yaml.string(), ": ", key, " ", s.error().message);
  return v;
}

// A binary PGM: its size and its pixels, row 0 at the top.
struct Pgm {
  int width = 0, height = 0, maxval = 0;
  std::string pixels;
};

Expected<Pgm> readPgm(const fs::path& p) {
  auto bytes = readWhole(p);
  if (!bytes) return bytes.error();
  const std::string& b = *bytes;
  size_t at = 0;
  // The header: "P5", width, height, maxval, whitespace- and comment-separated.
  const auto field = [&]() -> int64_t {
    while (at < b.size()) {
      if (b[at] == '#') {
        while (at < b.size() && b[at] != '\n') ++at;
      } else if (std::isspace(static_cast<unsigned char>(b[at]))) {
        ++at;
      } else {
        break;
      }
    }
    int64_t v = 0;
    size_t digits = 0;
    for (; at < b.size() && std::isdigit(static_cast<unsigned char>(b[at])) && digits < 9; ++at)
      v = 10 * v + (b[at] - '0'), ++digits;
    return digits == 0 ? -1 : v;
  };
  if (b.compare(0, 2, "P5") != 0) return makeError(p.string(), ": not a binary PGM (P5)");
  at = 2;
  const int64_t w = field(), h = field(), maxval = field();
  if (w <= 0 || h <= 0 || maxval <= 0 || maxval > 255 || at >= b.size() ||
      !std::isspace(static_cast<unsigned char>(b[at])))
    return makeError(p.string(), ": malformed PGM header");
  ++at;  // the single whitespace before the pixels
  if (w * h > kMaxCells) return makeError(p.string(), ": ", w, "x", h, " cells is too large");
  if (static_cast<int64_t>(b.size() - at) != w * h)
    return makeError(p.string(), ": ", b.size() - at, " bytes of pixels for ", w, "x", h);
  return Pgm{static_cast<int>(w), static_cast<int>(h), static_cast<int>(maxval), b.substr(at)};
}

}  // namespace

Expected<PlanImage> readPlan(const fs::path& yaml) {
  static const std::regex name(R"(floor-(-?[0-9]{1,6})\.yaml)");
  std::smatch m;
  const std::string file = yaml.filename().string();
  if (!std::regex_match(file, m, name)) return makeError(yaml.string(), ": not floor-N.yaml");
  auto keys = yamlKeys(yaml);
  if (!keys) return keys.error();
  PlanImage plan;
  plan.floor = std::stoi(m[1].str());
  auto res = number(yaml, "resolution", keys->at("resolution"));
  auto occupied = number(yaml, "occupied_thresh", keys->at("occupied_thresh"));
  auto free = number(yaml, "free_thresh", keys->at("free_thresh"));
  for (const auto* v : {&res, &occupied, &free})
    if (!*v) return v->error();
  if (!(*res > 0.0)) return makeError(yaml.string(), ": resolution must be positive");
  plan.resolution_m = *res;
  // origin: [x, y, yaw]
  std::string origin = keys->at("origin");
  std::replace_if(
      origin.begin(), origin.end(), [](char c) { return c == '[' || c == ']'; }, ' ');
  std::istringstream o(origin);
  std::string part;
  std::vector<double> xyz;
  while (std::getline(o, part, ',')) {
    auto v = number(yaml, "origin",
                    std::string(part.begin() + part.find_first_not_of(' '),
                                part.begin() + part.find_last_not_of(' ') + 1));
    if (!v) return v.error();
    xyz.push_back(*v);
  }
  if (xyz.size() != 3) return makeError(yaml.string(), ": origin is not [x, y, yaw]");
  plan.origin_x = xyz[0], plan.origin_y = xyz[1], plan.origin_yaw = xyz[2];
  const bool negate = keys->count("negate") && keys->at("negate") == "1";
  const fs::path image = fs::path(keys->at("image")).is_absolute()
                             ? fs::path(keys->at("image"))
                             : yaml.parent_path() / keys->at("image");
  auto pgm = readPgm(image);
  if (!pgm) return makeError(yaml.filename().string(), ": ", pgm.error().message);
  plan.width = pgm->width;
  plan.height = pgm->height;
  plan.cells.resize(static_cast<size_t>(plan.width) * plan.height);
  for (int row = 0; row < plan.height; ++row) {
    for (int i = 0; i < plan.width; ++i) {
      const auto v =
          static_cast<unsigned char>(pgm->pixels[static_cast<size_t>(row) * plan.width + i]);
      const double p = negate ? v / double(pgm->maxval) : (pgm->maxval - v) / double(pgm->maxval);
      const uint8_t c = p > *occupied ? 2 : (p < *free ? 1 : 0);
      plan.cells[static_cast<size_t>(plan.height - 1 - row) * plan.width + i] = c;
    }
  }
  return plan;
}

std::string plansText(const std::vector<PlanImage>& plans, const std::string& dir,
                      int64_t refused) {
  JsonWriter j;
  j.beginObject().key("type").value("plans").key("dir").value(dir).key("refused").value(refused);
  j.key("floors").beginArray();
  for (const PlanImage& p : plans) {
    int64_t counts[3] = {0, 0, 0};
    std::string runs;
    for (size_t k = 0; k < p.cells.size();) {
      size_t n = 1;
      while (k + n < p.cells.size() && p.cells[k + n] == p.cells[k]) ++n;
      runs += "ufo"[p.cells[k]];
      runs += std::to_string(n);
      counts[p.cells[k]] += static_cast<int64_t>(n);
      k += n;
    }
    j.beginObject().key("floor").value(p.floor).key("resolution_m").value(p.resolution_m, 4);
    j.key("origin").beginArray().value(p.origin_x, 4).value(p.origin_y, 4);
    j.value(p.origin_yaw, 5).endArray();
    j.key("width").value(p.width).key("height").value(p.height);
    j.key("free").value(counts[1]).key("occupied").value(counts[2]);
    j.key("cells").value(runs).endObject();
  }
  j.endArray().endObject();
  return j.take();
}

std::optional<std::string> PlanFolder::poll() {
  static const std::regex name(R"(floor-(-?[0-9]{1,6})\.(yaml|pgm))");
  std::vector<fs::path> yamls;
  std::string listing;
  std::error_code ec;
  std::vector<fs::directory_entry> entries;
  for (const auto& e : fs::directory_iterator(dir_, ec)) entries.push_back(e);
  std::sort(entries.begin(), entries.end());
  for (const auto& e : entries) {
    const std::string file = e.path().filename().string();
    if (!std::regex_match(file, name)) continue;
    std::error_code e1, e2;
    const auto size = e.file_size(e1);
    const auto time = e.last_write_time(e2).time_since_epoch().count();
    listing +=
        file + " " + std::to_string(e1 ? 0 : size) + " " + std::to_string(e2 ? 0 : time) + "\n";
    if (e.path().extension() == ".yaml") yamls.push_back(e.path());
  }
  if (ec) listing = "unreadable: " + ec.message();
  if (polled_ && listing == last_listing_) return std::nullopt;
  polled_ = true;
  last_listing_ = listing;
  if (ec) {
    std::fprintf(stderr, "evermap-viewer: %s: cannot be read (%s)\n", dir_.c_str(),
                 ec.message().c_str());
    ++refused_;
  }
  std::vector<PlanImage> plans;
  for (const fs::path& yaml : yamls) {
    auto plan = readPlan(yaml);
    if (!plan) {
      std::fprintf(stderr, "evermap-viewer: %s\n", plan.error().message.c_str());
      ++refused_;
      continue;
    }
    plans.push_back(std::move(*plan));
  }
  return plansText(plans, dir_.string(), refused_);
}

PlanWatcher::PlanWatcher(fs::path dir, Board& board, WebServer& server, double period_s)
    : folder_(std::move(dir)), board_(board), server_(server), period_s_(period_s) {
  thread_ = std::thread([this] { run(); });
}

PlanWatcher::~PlanWatcher() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void PlanWatcher::run() {
  std::unique_lock lock(mutex_);
  while (!stop_) {
    lock.unlock();
    if (auto text = folder_.poll()) {
      board_.post(Topic::kPlans, std::move(*text));
      server_.notify();
    }
    lock.lock();
    wake_.wait_for(lock, std::chrono::duration<double>(period_s_), [this] { return stop_; });
  }
}

}  // namespace evermap::viewer
