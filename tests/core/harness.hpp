// A minimal test harness for the core's C++ tests (no dependency): TEST(name) registers a function, CHECK and
// CHECK_NEAR record failures with their file and line, main() runs every test and returns the failure count.
#pragma once

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace pfield::testing {

struct Registry {
  std::vector<std::pair<std::string, std::function<void()>>> tests;
  int failures = 0;
  static Registry& get() {
    static Registry registry;
    return registry;
  }
};

struct Register {
  Register(const char* name, std::function<void()> body) { Registry::get().tests.emplace_back(name, std::move(body)); }
};

inline void fail(const char* file, int line, const std::string& what) {
  std::fprintf(stderr, "%s:%d: FAILED %s\n", file, line, what.c_str());
  ++Registry::get().failures;
}

}  // namespace pfield::testing

#define PFIELD_CONCAT_(a, b) a##b
#define PFIELD_CONCAT(a, b) PFIELD_CONCAT_(a, b)
#define TEST(name)                                                                      \
  static void name();                                                                   \
  static const ::pfield::testing::Register PFIELD_CONCAT(register_, name)(#name, name); \
  static void name()
#define CHECK(condition) \
  ((condition) ? (void)0 : ::pfield::testing::fail(__FILE__, __LINE__, #condition))
#define CHECK_NEAR(actual, expected, tolerance)                                                            \
  do {                                                                                                     \
    const double a_ = (actual), e_ = (expected);                                                           \
    if (!(std::abs(a_ - e_) <= (tolerance)))                                                               \
      ::pfield::testing::fail(__FILE__, __LINE__,                                                          \
                              std::string(#actual " = ") + std::to_string(a_) + ", expected " + std::to_string(e_)); \
  } while (false)
