// Options given on the command line for one test (PetscOptionsSetValue), removed again at its end
// with the option registrations (options::clear).
#pragma once

#include <petscsys.h>

#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "morse/core/options.hpp"

namespace morse::test {

struct GivenOptions {
  std::vector<std::string> names;
  GivenOptions() = default;
  GivenOptions(std::initializer_list<std::pair<const char*, const char*>> given) {
    for (const auto& [name, value] : given) {
      PetscOptionsSetValue(nullptr, name, value);
      names.emplace_back(name);
    }
  }
  ~GivenOptions() {
    for (const auto& n : names) PetscOptionsClearValue(nullptr, n.c_str());
    options::clear();
  }
};

}  // namespace morse::test
