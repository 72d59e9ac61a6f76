// libFuzzer harness: a package.xml through packageNameOf() (the package:// resolver) (see fuzz_targets.h; built with
// -DFLUID_SIM_FUZZ=ON, run by scripts/fuzz.sh).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fluid_sim::fuzz::runPackageXml(data, size);
  return 0;
}
