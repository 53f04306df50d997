#pragma once
// Error style (see CONTRIBUTING.md):
// - device I/O and anything on a capture path returns Result<T> / Status and never throws;
// - configuration and set-up code throws UserError, which the app turns into one clear message.
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace pvcap {

struct Error {
  std::string message;
  // The disk failed a read or write (EIO): a command that skips a damaged frame must not skip this
  // one, but fail naming the file (docs/store.md, what a failing disk gets).
  bool disk_failed = false;
};

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : v_(std::move(error)) {}  // NOLINT
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() { return std::get<0>(v_); }
  const T& value() const { return std::get<0>(v_); }
  T* operator->() { return &value(); }
  T& operator*() { return value(); }
  const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)) {}  // NOLINT
  static Status ok_status() { return {}; }
  bool ok() const { return !error_.has_value(); }
  explicit operator bool() const { return ok(); }
  const Error& error() const { return *error_; }

 private:
  std::optional<Error> error_;
};

// A failure the user can fix (bad config, missing device, full disk): its message
// is shown as is, without a stack of library noise.
class UserError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace pvcap
