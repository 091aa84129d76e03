// Runs every TEST of tests/core; the exit code is the number of failures (ctest reads it).
#include <cstdio>

#include "harness.hpp"

int main() {
  auto& registry = pfield::testing::Registry::get();
  for (const auto& [name, body] : registry.tests) {
    const int before = registry.failures;
    body();
    std::printf("%-60s %s\n", name.c_str(), registry.failures == before ? "ok" : "FAILED");
  }
  std::printf("%zu tests, %d failures\n", registry.tests.size(), registry.failures);
  return registry.failures == 0 ? 0 : 1;
}
