// Result<T>: a value or the Error that prevented it, for a function off the
// hot path that produces something. A function that produces nothing returns
// Error itself (see base/error.hpp).
//
//   Result<Config> r = load(path);
//   if (!r.ok()) return r.error();
//   use(r.value());
//
// Result has no operator bool on purpose: std::optional and std::expected
// read "true" as "has a value", Error reads "true" as "failed"; either
// reading would surprise half of the readers, so callers say ok().
//
// A failed Result always holds a failure: built from an Error whose kind is
// kOk it holds kInternal instead (an invariant that did not hold), so a
// caller never mistakes "no value" for success.
//
// Thread contract: plain value type; any thread, one at a time per object.
#pragma once

#include "base/error.hpp"

#include <type_traits>
#include <utility>
#include <variant>

namespace cobridge {

template <class T>
class Result {
  static_assert(!std::is_same_v<std::remove_cv_t<T>, Error>, "Result<Error> is ambiguous: return Error");
  static_assert(!std::is_reference_v<T>, "Result holds values");

 public:
  // Success.
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}  // NOLINT(google-explicit-constructor)
  // Failure.
  Result(Error error) : state_(std::in_place_index<1>, std::move(error)) {  // NOLINT(google-explicit-constructor)
    Error& e = std::get<1>(state_);
    if (e.kind == Errc::kOk) e.kind = Errc::kInternal;
  }

  [[nodiscard]] bool ok() const noexcept { return state_.index() == 0; }

  // The value; only when ok() (a failed Result throws std::bad_variant_access:
  // asking for it is a bug).
  [[nodiscard]] T& value() & { return std::get<0>(state_); }
  [[nodiscard]] const T& value() const& { return std::get<0>(state_); }
  [[nodiscard]] T&& value() && { return std::get<0>(std::move(state_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  // The failure; an empty (kOk) Error when ok(), so `return r.error();` from
  // a function returning Error is right in both cases.
  [[nodiscard]] Error error() const& { return ok() ? Error{} : std::get<1>(state_); }
  [[nodiscard]] Error error() && { return ok() ? Error{} : std::get<1>(std::move(state_)); }

  // The value, or `fallback` when failed.
  [[nodiscard]] T value_or(T fallback) const& { return ok() ? std::get<0>(state_) : std::move(fallback); }

 private:
  std::variant<T, Error> state_;
};

}  // namespace cobridge
