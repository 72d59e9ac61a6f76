// libFuzzer harness: a mesh file through readMeshFile() (assimp), its format forced by the file
// extension FLUID_SIM_FUZZ_MESH_EXT (".stl", ".obj", ".dae", ".ply"; one executable per format).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  fluid_sim::fuzz::runMesh(data, size, FLUID_SIM_FUZZ_MESH_EXT);
  return 0;
}
