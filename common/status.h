// Error reporting for every Vigil library: a status that names the file, line and key at fault.
// Libraries never print or exit; tools print Error::str() and exit 2 (bad input) or 1 (internal).
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace vigil {

enum class ErrorKind {
  kBadInput,  // the user's file, parameter or data is wrong (tools exit 2)
  kInternal,  // our bug or the environment failed (tools exit 1)
};

struct Error {
  ErrorKind kind = ErrorKind::kBadInput;
  std::string file;     // file at fault, empty when there is none
  int line = 0;         // 1-based line in that file, 0 when unknown
  std::string key;      // key path at fault, e.g. "people[1].script[0].to"
  std::string message;  // what is wrong, in words

  // "file:line: key: message" with absent parts left out.
  std::string str() const;
};

// Builds a bad-input error.
Error bad_input(std::string file, int line, std::string key, std::string message);
// Builds an internal error.
Error internal_error(std::string message);

// Success or an Error.
class Status {
 public:
  Status() = default;
  Status(Error e) : err_(std::move(e)), ok_(false) {}  // NOLINT: implicit by design
  static Status Ok() { return {}; }
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { return err_; }

 private:
  Error err_;
  bool ok_ = true;
};

// A value or an Error.
template <class T>
class Result {
 public:
  Result(T value) : v_(std::move(value)) {}   // NOLINT
  Result(Error e) : v_(std::move(e)) {}       // NOLINT
  Result(Status s) : v_(s.error()) {}         // NOLINT: only from a failed Status
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() { return std::get<0>(v_); }
  const T& value() const { return std::get<0>(v_); }
  T& operator*() { return value(); }
  const T& operator*() const { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  const Error& error() const { return std::get<1>(v_); }
  Status status() const { return ok() ? Status::Ok() : Status(error()); }

 private:
  std::variant<T, Error> v_;
};

}  // namespace vigil
