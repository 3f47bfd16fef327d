// Error channels of penumbra and the exit codes they map to (docs/design.md, "Exit codes").
#pragma once

#include <stdexcept>
#include <string>

namespace penumbra {

enum ExitCode : int {
    kExitSuccess = 0,
    kExitGateFailed = 1,
    kExitBadInput = 2,     // bad input or usage; the message names file, element, expectation
    kExitEnvironment = 3,  // no device, out of memory, device lost, Embree error
    kExitInternal = 4,     // a bug in penumbra: an invariant did not hold
};

// Bad user input. The message must say where (file, JSON path or glTF element) and what
// was expected: "scenario.json: lights[1].direction: zero vector".
class InputError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// The machine could not do what was asked (Embree or Vulkan failure, out of memory).
class EnvironmentError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

}  // namespace penumbra
