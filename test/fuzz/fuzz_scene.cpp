// libFuzzer harness: a scene's YAML text and its --set overrides through parseScene() (see fuzz_targets.h; built with
// -DFLUID_SIM_FUZZ=ON, run by scripts/fuzz.sh).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fluid_sim::fuzz::runScene(data, size);
  return 0;
}
