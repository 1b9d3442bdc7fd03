#pragma once
// Bad input and numerical failure are returned as values (STYLE.md, "Errors"): an
// Expected<T> holds either a T or an Error whose message names the input and what was wrong,
// in one line ("cam0/data.csv:12: expected 2 fields, got 1"). std::expected is C++23; this is
// the small part of it we use.

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <variant>

#include "core/common/number_text.h"

namespace evermap {

struct Error {
  std::string message;
};

// Builds an Error from parts: makeError("file.csv:", line, ": bad number").
template <typename... Args>
Error makeError(Args&&... parts) {
  std::string s;
  auto append = [&s](const auto& p) {
    using P = std::decay_t<decltype(p)>;
    if constexpr (std::is_floating_point_v<P>) {
      s += numberText(p);
    } else if constexpr (std::is_arithmetic_v<P>) {
      s += std::to_string(p);
    } else {
      s += p;
    }
  };
  (append(parts), ...);
  return Error{std::move(s)};
}

template <typename T>
class [[nodiscard]] Expected {
 public:
  Expected(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Expected(Error error) : v_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  // Contract: only call value() when ok(), error() when !ok(); a breach aborts with a message.
  T& value() & {
    check(true);
    return std::get<0>(v_);
  }
  const T& value() const& {
    check(true);
    return std::get<0>(v_);
  }
  // By value: `for (x : f().value())` must not point into a destroyed temporary.
  T value() && {
    check(true);
    return std::get<0>(std::move(v_));
  }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  const Error& error() const {
    check(false);
    return std::get<1>(v_);
  }

 private:
  void check(bool want_value) const {
    if (ok() != want_value) {
      std::fprintf(stderr, "evermap: Expected accessed as %s but holds %s%s%s\n",
                   want_value ? "value" : "error",
                   ok() ? "a value" : "error: ", ok() ? "" : std::get<1>(v_).message.c_str(), "");
      std::abort();
    }
  }
  std::variant<T, Error> v_;
};

// For operations that return nothing but may fail.
struct Ok {};
using Status = Expected<Ok>;

}  // namespace evermap
