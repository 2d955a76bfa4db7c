#include "bakers/bake/stop.h"

#include "bakers/bake/cancelled.h"

namespace kiln::bake {

void StopCheck::check() const {
  if (cancelled()) throw BakeCancelled();
  if (out_of_time()) throw OutOfTime();
}

}  // namespace kiln::bake
