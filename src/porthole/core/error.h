// Error kinds shared by every module (see docs/architecture.md, "three kinds of failure"):
//  - InvalidInput: bad input or options. Names the field and the rule it breaks; the CLI prints
//    the message on one line and exits with code 2.
//  - InternalError: a broken invariant inside porthole (a bug). Thrown by PORTHOLE_CHECK.
// Expected numerical outcomes (a ray misses the dome, total internal reflection, no convergence)
// are not errors: they are returned as a status or std::optional.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

namespace porthole {

class InvalidInput : public std::invalid_argument {
 public:
  // field: the name the user knows the value by (a CLI flag, a TOML key); rule: what was expected.
  InvalidInput(const std::string& field, const std::string& rule)
      : std::invalid_argument(field + ": " + rule), field_(field) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// Throws InvalidInput unless v is finite. Returns v so it can wrap an initialiser.
inline double RequireFinite(const std::string& field, double v) {
  if (!std::isfinite(v)) throw InvalidInput(field, "must be a finite number");
  return v;
}
inline double RequirePositive(const std::string& field, double v) {
  RequireFinite(field, v);
  if (!(v > 0)) throw InvalidInput(field, "must be > 0");
  return v;
}
inline double RequireNonNegative(const std::string& field, double v) {
  RequireFinite(field, v);
  if (!(v >= 0)) throw InvalidInput(field, "must be >= 0");
  return v;
}

}  // namespace porthole

#define PORTHOLE_CHECK(cond)                                                               \
  do {                                                                                     \
    if (!(cond))                                                                           \
      throw ::porthole::InternalError(std::string(__FILE__) + ":" + std::to_string(__LINE__) + \
                                      ": check failed: " #cond);                           \
  } while (0)
