// FieldError: a bad value of one options field, thrown by an options struct's
// Validate(). (Its own header rather than error.h, which nearly every file includes.)
#pragma once

#include <string>
#include <utility>

#include "common/error.h"

namespace drape {

// Carries the address of the offending member, so a caller that filled the struct
// (the recipe parser) can tell which of its keys set it without reading the message,
// and the field's name and the reason separately. what() is "name: reason".
class FieldError : public Error {
 public:
  FieldError(const void* field, std::string name, std::string reason)
      : Error(name + ": " + reason), field_(field), name_(std::move(name)), reason_(std::move(reason)) {}
  const void* field() const { return field_; }
  const std::string& name() const { return name_; }
  const std::string& reason() const { return reason_; }

 private:
  const void* field_;
  std::string name_, reason_;
};

// Throws FieldError for `field`, a member of the struct being validated, e.g.
//   if (!(time_step > 0)) BadField(time_step, "time_step", "must be > 0 s");
template <typename T>
[[noreturn]] void BadField(const T& field, std::string name, std::string reason) {
  throw FieldError(&field, std::move(name), std::move(reason));
}

}  // namespace drape
