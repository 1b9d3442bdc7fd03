#pragma once
// A JSON text written front to back: what the viewer sends to the page. Output only (the
// viewer parses no JSON). Numbers that are not finite are written as null, so one bad value
// never makes the whole text unreadable to the browser.
//
//   JsonWriter j;
//   j.beginObject().key("type").value("pose").key("xyz").beginArray();
//   for (double v : xyz) j.value(v, 3);
//   j.endArray().endObject();
//   std::string text = j.take();
//
// Commas are placed by the writer; a key must precede every value inside an object (a broken
// contract otherwise, checked).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace evermap::viewer {

class JsonWriter {
 public:
  JsonWriter& beginObject();
  JsonWriter& endObject();
  JsonWriter& beginArray();
  JsonWriter& endArray();
  JsonWriter& key(std::string_view k);
  JsonWriter& value(std::string_view s);
  JsonWriter& value(const char* s) { return value(std::string_view(s)); }
  JsonWriter& value(int64_t v);
  JsonWriter& value(int v) { return value(static_cast<int64_t>(v)); }
  JsonWriter& value(bool v);
  // `decimals` digits after the point (fixed notation); a value that is not finite is null.
  JsonWriter& value(double v, int decimals);
  JsonWriter& null();
  // A value that is already JSON text (written by another JsonWriter: not checked).
  JsonWriter& raw(std::string_view json);

  // The text so far (complete when every begin has its end).
  const std::string& text() const { return out_; }
  std::string take();

 private:
  void beforeValue();
  // Starts or ends an object (true) or an array (false).
  JsonWriter& open(bool object);
  JsonWriter& close(bool object);
  void writeString(std::string_view s);
  std::string out_;
  // One entry per open container: true = object. `first_` says whether it is still empty.
  std::vector<bool> object_;
  std::vector<bool> first_;
  bool after_key_ = false;
};

}  // namespace evermap::viewer
