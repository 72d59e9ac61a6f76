// libFuzzer harness: a particle frame (fluid: - particles: {file}) through readPlyFrame() (see fuzz_targets.h; built
// with -DFLUID_SIM_FUZZ=ON, run by scripts/fuzz.sh).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fluid_sim::fuzz::runPlyFrame(data, size);
  return 0;
}
