// The exception a bake throws when its BakeControl::cancel flag was set.
#pragma once

#include <stdexcept>

namespace kiln::bake {

// Nothing is returned: a cancelled bake has no partial result.
class BakeCancelled : public std::runtime_error {
 public:
  BakeCancelled() : std::runtime_error("the bake was cancelled before it finished") {}
};

}  // namespace kiln::bake
