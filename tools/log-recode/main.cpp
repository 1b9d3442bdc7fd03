// evermap-log-recode: copies an LCM log with its images re-encoded (STEREO's two images, RGBD's
// gray image and depth), every other event unchanged and in order. Lossless either way: the
// decoded pixels are the same, so a log recorded with PNG images (before zstd became the
// default) replays ~7x cheaper to decode once recoded, and a zstd log can be turned back into
// PNG for other tools.
//
//   evermap-log-recode IN.lcmlog OUT.lcmlog [--encoding zstd|png|gray8]
//
// Prints the frames recoded and the image bytes per frame before and after. A frame that does
// not decode is copied as it was and counted (one line names the first). Exits 0 on success,
// 1 when the input is damaged or the output cannot be written, 2 on bad usage.
#include <cstdio>
#include <string>
#include <vector>

#include <evermap/rgbd_image_t.hpp>
#include <evermap/stereo_image_t.hpp>

#include "core/common/command_line.h"
#include "core/common/option_fields.h"
#include "core/messages/channels.h"
#include "core/messages/convert.h"
#include "core/messages/rgbd_convert.h"
#include "tools/lcmlog/log_reader.h"
#include "tools/lcmlog/log_writer.h"

namespace {

using evermap::Expected;
using evermap::makeError;
namespace messages = evermap::messages;

struct RecodeOptions {
  messages::ImageEncoding encoding = messages::ImageEncoding::kZstd;
  void declareOptions(evermap::OptionList& o) {
    o.choice("encoding", &encoding, messages::imageEncodingNames(),
             "the images' encoding in the output: zstd rows (decode fastest), png (other tools "
             "read it) or gray8 (raw)");
  }
};

struct Tally {
  int64_t frames = 0, kept = 0, bytes_in = 0, bytes_out = 0;
  std::string first_kept;
};

template <typename Msg>
Expected<std::vector<uint8_t>> encoded(const Msg& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  if (msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) !=
      static_cast<int>(bytes.size())) {
    return makeError("cannot encode ", Msg::getTypeName());
  }
  return bytes;
}

// A frame message of type Msg (stereo_image_t or rgbd_image_t) re-encoded.
template <typename Msg>
Expected<std::vector<uint8_t>> recodeAs(const messages::LogReader::Event& e,
                                        messages::ImageEncoding encoding) {
  auto msg = messages::decodeLcm<Msg>(e.data, e.datalen, e.channel);
  if (!msg) return msg.error();
  auto frame = messages::fromMsg(*msg);
  if (!frame) return frame.error();
  auto out = messages::toMsg(*frame, encoding);
  if (!out) return out.error();
  return encoded(*out);
}

// A frame event's bytes re-encoded, or the error that keeps it as it was.
Expected<std::vector<uint8_t>> recode(const messages::LogReader::Event& e,
                                      messages::ImageEncoding encoding) {
  if (e.channel == evermap::channels::kStereo)
    return recodeAs<evermap::stereo_image_t>(e, encoding);
  return recodeAs<evermap::rgbd_image_t>(e, encoding);
}

int run(const std::string& in, const std::string& out, messages::ImageEncoding encoding) {
  auto reader = messages::LogReader::open(in);
  if (!reader)
    return std::fprintf(stderr, "evermap-log-recode: %s\n", reader.error().message.c_str()), 1;
  auto writer = messages::LogWriter::open(out);
  if (!writer)
    return std::fprintf(stderr, "evermap-log-recode: %s\n", writer.error().message.c_str()), 1;
  Tally t;
  while (const messages::LogReader::Event* e = reader->next()) {
    std::vector<uint8_t> data(e->data, e->data + e->datalen);
    if (e->channel == evermap::channels::kStereo || e->channel == evermap::channels::kRgbd) {
      auto recoded = recode(*e, encoding);
      ++t.frames;
      t.bytes_in += e->datalen;
      if (recoded) {
        data = std::move(*recoded);
      } else if (t.kept++ == 0) {
        t.first_kept = recoded.error().message;
      }
      t.bytes_out += static_cast<int64_t>(data.size());
    }
    if (evermap::Status s = writer->writeBytes(e->channel, e->timestamp, data); !s) {
      return std::fprintf(stderr, "evermap-log-recode: %s: %s\n", out.c_str(),
                          s.error().message.c_str()),
             1;
    }
  }
  if (evermap::Status s = reader->status(); !s) {
    return std::fprintf(stderr, "evermap-log-recode: %s\n", s.error().message.c_str()), 1;
  }
  if (evermap::Status s = writer->commit(); !s) {
    return std::fprintf(stderr, "evermap-log-recode: %s: %s\n", out.c_str(),
                        s.error().message.c_str()),
           1;
  }
  if (t.kept > 0) {
    std::fprintf(
        stderr,
        "evermap-log-recode: %s: %lld frames did not decode, copied as they were (first: %s)\n",
        in.c_str(), static_cast<long long>(t.kept), t.first_kept.c_str());
  }
  const double n = t.frames > 0 ? static_cast<double>(t.frames) : 1.0;
  std::printf(
      "frames %lld encoding %s bytes_per_frame_in %.0f bytes_per_frame_out %.0f kept %lld\n",
      static_cast<long long>(t.frames), messages::toString(encoding), t.bytes_in / n,
      t.bytes_out / n, static_cast<long long>(t.kept));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  RecodeOptions options;
  evermap::CommandLine cli("evermap-log-recode",
                           "Copies an LCM log with its images re-encoded (lossless).");
  cli.positional(&files, "IN.lcmlog OUT.lcmlog", "the log to read and the log to write");
  cli.options(&options);
  cli.alias("--encoding", "encoding", "zstd|png|gray8");
  if (const int code = cli.parseOrExit(argc, argv); code >= 0) return code;
  if (files.size() != 2) {
    std::fprintf(stderr, "evermap-log-recode: needs IN.lcmlog and OUT.lcmlog, got %zu files\n%s",
                 files.size(), cli.usage().c_str());
    return 2;
  }
  return run(files[0], files[1], options.encoding);
}
