#include "fluid_sim/io/scene_loader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "fluid_sim/io/mesh_topology.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
using io::loadScene;
using io::parseScene;
using io::SceneError;

// Every key of the schema, with values other than the defaults.
const char* const kFullScene = R"yaml(
spacing: 0.02                 # m
rest_density: 998.0
gravity: [0, 0, -9.81]
domain: {min: [-1, -1, -1], max: [2, 2, 2]}
time_step: {cfl: 0.3, min: 2.0e-5, max: 0.004}
solver:
  boundary_pressure: sph
  density_error: 0.002
  divergence_error: 0.003
  min_iterations: 3
  max_iterations: 90
  min_divergence_iterations: 2
  divergence_solve: false
  warm_start: true
  warm_start_divergence: true
  cold_start: jacobi
  warm_start_guess: damped
  omega: 0.6
  chebyshev_rho: 0.9
  chebyshev_delay: 4
  clamp_boundary_pressure: false
  mls_fit_radius: 2.5
  mls_eigen_tolerance: 0.05
  mls_singular: pseudo_inverse
viscosity: {model: xsph, coefficient: 0.01, boundary: 0.02}
fill: {trim: false, relax: false, relax_tolerance: 0.01, relax_max_steps: 20}
stability: {max_density_error: 0.2, max_cfl: 1.5}
duration: 2.5
fluid:
  - box: {min: [0, 0, 0], max: [0.2, 0.1, 0.4]}
    velocity: [1, 0, 0]
  - box: {min: [0.5, 0, 0], max: [0.6, 0.1, 0.1]}
boundaries:
  - name: tank
    box: {min: [0, 0, 0], max: [1.0, 0.1, 0.6]}
    inside: true
  - sphere: {center: [0.5, 0.05, 0.3], radius: 0.05}
    dynamic:
      mass: 0.4
      inertia: [4.0e-4, 5.0e-4, 6.0e-4, 1.0e-5, 2.0e-5, 3.0e-5]
      center_of_mass: [0.01, 0, -0.02]
      linear_velocity: [0.1, 0.2, 0.3]
      angular_velocity: [0, 0, 2]
  - name: drum
    cylinder: {center: [0, 0, 0], axis: [0, 1, 0], radius: 0.3, length: 0.2}
    inside: true
    motion: {angular_velocity: [0, 0.73, 0], about: [0, 0, 0.1], linear_velocity: [0.1, 0, 0], start: 0.5, ramp: 0.25}
    pose: {xyz: [0.1, 0.2, 0.3], rpy: [0, 0, 1.5707963267948966]}
    sample_spacing: 0.01
  - name: part
    mesh:
      vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
      triangles: [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    offset: none
    external: true
output: {frame_interval: 0.02}
contacts: {friction: 0.3}
)yaml";

// A small valid scene; tests add keys to it.
const std::string kBase = R"yaml(
spacing: 0.05
domain: {min: [0, 0, 0], max: [1, 1, 1]}
fluid:
  - box: {min: [0.1, 0.1, 0.1], max: [0.5, 0.5, 0.5]}
)yaml";

const std::string kBoundaries = R"yaml(
boundaries:
  - name: tank
    box: {min: [0, 0, 0], max: [1, 1, 1]}
    inside: true
  - name: ball
    sphere: {center: [0.7, 0.7, 0.7], radius: 0.1}
)yaml";

/// Parses `yaml` as "scene.yaml" and returns the error message ("" if there was none).
std::string errorOf(const std::string& yaml, const std::vector<std::string>& overrides = {})
{
  try
  {
    parseScene(yaml, "scene.yaml", overrides);
  }
  catch (const SceneError& e)
  {
    return e.what();
  }
  return "";
}

/// The message names the file and the key, as "scene.yaml: <key>: ...".
void expectError(const std::string& yaml, const std::string& key, const std::string& detail = "",
                 const std::vector<std::string>& overrides = {})
{
  const std::string what = errorOf(yaml, overrides);
  EXPECT_NE(what.find(key.empty() ? "scene.yaml: " : "scene.yaml: " + key + ": "), std::string::npos)
      << "message: " << what;
  EXPECT_NE(what.find(detail), std::string::npos) << "message: " << what;
}

TEST(SceneLoader, FullExampleParses)
{
  const SceneConfig s = parseScene(kFullScene, "full.yaml");
  EXPECT_EQ(s.source, "full.yaml");
  EXPECT_DOUBLE_EQ(s.spacing, 0.02);
  EXPECT_DOUBLE_EQ(s.rest_density, 998.0);
  EXPECT_TRUE(s.gravity.isApprox(Vec3d(0, 0, -9.81)));
  EXPECT_TRUE(s.domain.min.isApprox(Vec3d(-1, -1, -1)));
  EXPECT_TRUE(s.domain.max.isApprox(Vec3d(2, 2, 2)));
  EXPECT_TRUE(s.time_step.adaptive);
  EXPECT_DOUBLE_EQ(s.time_step.cfl, 0.3);
  EXPECT_DOUBLE_EQ(s.time_step.min, 2.0e-5);
  EXPECT_DOUBLE_EQ(s.time_step.max, 0.004);

  EXPECT_EQ(s.solver.boundary_pressure, BoundaryPressureMethod::SphExtrapolation);
  EXPECT_DOUBLE_EQ(s.solver.density_error, 0.002);
  EXPECT_DOUBLE_EQ(s.solver.divergence_error, 0.003);
  EXPECT_EQ(s.solver.min_iterations, 3);
  EXPECT_EQ(s.solver.max_iterations, 90);
  EXPECT_EQ(s.solver.min_divergence_iterations, 2);
  EXPECT_FALSE(s.solver.divergence_solve);
  EXPECT_TRUE(s.solver.warm_start);
  EXPECT_TRUE(s.solver.warm_start_divergence);        // the default is false
  EXPECT_EQ(s.solver.cold_start, ColdStart::Jacobi);  // the default is zero
  EXPECT_EQ(s.solver.warm_start_guess, WarmStartGuess::Damped);
  EXPECT_DOUBLE_EQ(s.solver.omega, 0.6);
  EXPECT_DOUBLE_EQ(s.solver.chebyshev_rho, 0.9);
  EXPECT_EQ(s.solver.chebyshev_delay, 4);
  EXPECT_FALSE(s.solver.clamp_boundary_pressure);
  EXPECT_DOUBLE_EQ(s.solver.mls_fit_radius, 2.5);
  EXPECT_DOUBLE_EQ(s.solver.mls_eigen_tolerance, 0.05);
  EXPECT_EQ(s.solver.mls_singular, MlsSingularMode::PseudoInverse);

  EXPECT_EQ(s.viscosity.model, ViscosityModel::Xsph);
  EXPECT_DOUBLE_EQ(s.viscosity.coefficient, 0.01);
  EXPECT_DOUBLE_EQ(s.viscosity.boundary, 0.02);
  EXPECT_DOUBLE_EQ(s.stability.max_density_error, 0.2);
  EXPECT_DOUBLE_EQ(s.stability.max_cfl, 1.5);
  EXPECT_DOUBLE_EQ(s.duration, 2.5);
  EXPECT_DOUBLE_EQ(s.output.frame_interval, 0.02);
  EXPECT_FALSE(s.fill.trim);
  EXPECT_FALSE(s.fill.relax);
  EXPECT_DOUBLE_EQ(s.fill.relax_tolerance, 0.01);
  EXPECT_EQ(s.fill.relax_max_steps, 20);

  ASSERT_EQ(s.fluid.size(), 2u);
  EXPECT_TRUE(s.fluid[0].box.max.isApprox(Vec3d(0.2, 0.1, 0.4)));
  EXPECT_TRUE(s.fluid[0].velocity.isApprox(Vec3d(1, 0, 0)));
  EXPECT_TRUE(s.fluid[1].velocity.isZero());

  ASSERT_EQ(s.boundaries.size(), 4u);
  const BoundaryConfig& tank = s.boundaries[0];
  EXPECT_EQ(tank.name, "tank");
  EXPECT_EQ(tank.type, ShapeType::Box);
  EXPECT_TRUE(tank.inside);
  EXPECT_TRUE(tank.box.max.isApprox(Vec3d(1.0, 0.1, 0.6)));
  EXPECT_TRUE(tank.motion.isStatic());
  EXPECT_FALSE(tank.externally_posed);

  const BoundaryConfig& ball = s.boundaries[1];
  EXPECT_EQ(ball.name, "sphere1");  // default name: shape type and index
  EXPECT_EQ(ball.type, ShapeType::Sphere);
  EXPECT_FALSE(ball.inside);
  EXPECT_TRUE(ball.sphere.center.isApprox(Vec3d(0.5, 0.05, 0.3)));
  EXPECT_DOUBLE_EQ(ball.sphere.radius, 0.05);
  EXPECT_TRUE(ball.dynamic.enabled);
  EXPECT_DOUBLE_EQ(ball.dynamic.mass, 0.4);
  EXPECT_DOUBLE_EQ(ball.dynamic.density, 0.0);
  ASSERT_TRUE(ball.dynamic.inertia.has_value());
  EXPECT_EQ(*ball.dynamic.inertia, (std::array<double, 6>{4.0e-4, 5.0e-4, 6.0e-4, 1.0e-5, 2.0e-5, 3.0e-5}));
  ASSERT_TRUE(ball.dynamic.center_of_mass.has_value());
  EXPECT_TRUE(ball.dynamic.center_of_mass->isApprox(Vec3d(0.01, 0, -0.02)));
  EXPECT_TRUE(ball.dynamic.linear_velocity.isApprox(Vec3d(0.1, 0.2, 0.3)));
  EXPECT_TRUE(ball.dynamic.angular_velocity.isApprox(Vec3d(0, 0, 2)));
  EXPECT_FALSE(tank.dynamic.enabled);
  EXPECT_DOUBLE_EQ(s.contacts.friction, 0.3);

  const BoundaryConfig& drum = s.boundaries[2];
  EXPECT_EQ(drum.type, ShapeType::Cylinder);
  EXPECT_TRUE(drum.cylinder.axis.isApprox(Vec3d(0, 1, 0)));
  EXPECT_DOUBLE_EQ(drum.cylinder.radius, 0.3);
  EXPECT_DOUBLE_EQ(drum.cylinder.length, 0.2);
  EXPECT_TRUE(drum.motion.angular_velocity.isApprox(Vec3d(0, 0.73, 0)));
  EXPECT_TRUE(drum.motion.about.isApprox(Vec3d(0, 0, 0.1)));
  EXPECT_TRUE(drum.motion.linear_velocity.isApprox(Vec3d(0.1, 0, 0)));
  EXPECT_DOUBLE_EQ(drum.motion.start, 0.5);
  EXPECT_DOUBLE_EQ(drum.motion.ramp, 0.25);
  EXPECT_TRUE(drum.pose.translation.isApprox(Vec3d(0.1, 0.2, 0.3)));
  EXPECT_TRUE(drum.pose.apply(Vec3d(1, 0, 0)).isApprox(Vec3d(0.1, 1.2, 0.3), 1e-12));  // yaw 90 degrees
  EXPECT_DOUBLE_EQ(drum.sample_spacing, 0.01);
  EXPECT_FALSE(drum.externally_posed);  // a scripted body is not also posed from outside

  const BoundaryConfig& part = s.boundaries[3];
  EXPECT_EQ(part.type, ShapeType::Mesh);
  EXPECT_EQ(part.mesh.vertices.size(), 4u);
  EXPECT_EQ(part.mesh.triangles.size(), 4u);
  EXPECT_TRUE(part.mesh_closed);
  EXPECT_EQ(part.mesh_offset, SurfaceOffset::None);
  EXPECT_TRUE(part.externally_posed);
}

TEST(SceneLoader, DefaultsForAbsentKeys)
{
  const SceneConfig s = parseScene(kBase, "scene.yaml");
  const SceneConfig defaults;
  EXPECT_FALSE(s.time_step.adaptive);
  EXPECT_DOUBLE_EQ(s.time_step.fixed, defaults.time_step.fixed);
  EXPECT_EQ(s.solver.boundary_pressure, defaults.solver.boundary_pressure);
  EXPECT_EQ(s.solver.cold_start, ColdStart::Zero);
  EXPECT_EQ(s.solver.warm_start_guess, WarmStartGuess::Previous);
  EXPECT_FALSE(s.solver.warm_start_divergence);   // the warm start's divergence solve starts cold
  EXPECT_DOUBLE_EQ(s.solver.chebyshev_rho, 0.0);  // Eq. A8a off by default: plain sweeps
  EXPECT_EQ(s.solver.chebyshev_delay, 3);
  EXPECT_DOUBLE_EQ(s.rest_density, defaults.rest_density);
  EXPECT_TRUE(s.boundaries.empty());
  EXPECT_DOUBLE_EQ(s.duration, defaults.duration);
}

TEST(SceneLoader, AProbeOutsideTheDomainIsWarnedAbout)
{
  const SceneConfig inside = parseScene(kBase + "probes: [{name: p, position: [0.5, 0.5, 0.2]}]\n", "scene.yaml");
  EXPECT_TRUE(inside.warnings.empty());
  const SceneConfig outside = parseScene(kBase + "probes: [{name: p, position: [9, 9, 9]}]\n", "scene.yaml");
  ASSERT_EQ(outside.warnings.size(), 1u);
  EXPECT_NE(outside.warnings[0].find("probes[0] 'p'"), std::string::npos) << outside.warnings[0];
  EXPECT_NE(outside.warnings[0].find("outside the domain"), std::string::npos) << outside.warnings[0];
  // Regions and sinks that miss the domain altogether, as placed (a box by its pose), too; one
  // that reaches into it is not.
  const SceneConfig regions =
      parseScene(kBase +
                     "regions:\n  - {name: far, sphere: {center: [3, 0.5, 0.5], radius: 0.5}}\n"
                     "  - {name: near, sphere: {center: [1.2, 0.5, 0.5], radius: 0.5}}\n"
                     "  - {name: moved, box: {min: [0, 0, 0], max: [0.2, 0.2, 0.2]}, pose: {xyz: "
                     "[0, 0, -1]}}\nsinks:\n  - {name: drain, box: {min: [0, 0, 2], max: [1, 1, "
                     "3]}}\n",
                 "scene.yaml");
  ASSERT_EQ(regions.warnings.size(), 3u);
  EXPECT_NE(regions.warnings[0].find("regions[0] 'far' lies wholly outside the domain"), std::string::npos);
  EXPECT_NE(regions.warnings[1].find("regions[2] 'moved'"), std::string::npos) << regions.warnings[1];
  EXPECT_NE(regions.warnings[2].find("sinks[0] 'drain'"), std::string::npos) << regions.warnings[2];
}

TEST(SceneLoader, LoadsFileAndNamesItInErrors)
{
  test::TempDir dir;
  const std::string good = dir.write("good.yaml", kBase + kBoundaries);
  EXPECT_EQ(loadScene(good).source, good);
  EXPECT_EQ(loadScene(good).boundaries.size(), 2u);

  const std::string bad = dir.write("bad.yaml", kBase + "solver: {density_eror: 0.001}\n");
  try
  {
    loadScene(bad);
    FAIL() << "no error";
  }
  catch (const SceneError& e)
  {
    EXPECT_EQ(e.file(), bad);
    EXPECT_EQ(e.key(), "solver.density_eror");
    EXPECT_NE(std::string(e.what()).find(bad + ": solver.density_eror: unknown key"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("did you mean 'density_error'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("line 6"), std::string::npos) << e.what();
  }
}

TEST(SceneLoader, MissingFileIsAnError)
{
  const std::string path = "/nonexistent/dir/scene.yaml";
  try
  {
    loadScene(path);
    FAIL() << "no error";
  }
  catch (const ConfigError& e)  // SceneError is a ConfigError
  {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
  }
}

TEST(SceneLoader, YamlSyntaxErrorNamesLine)
{
  const std::string what = errorOf("spacing: 0.05\ndomain: {min: [0, 0, 0], max: [1, 1, 1]\nfluid: []\n");
  EXPECT_NE(what.find("scene.yaml: "), std::string::npos) << what;
  EXPECT_NE(what.find("YAML syntax error at line"), std::string::npos) << what;
}

TEST(SceneLoader, UnknownTopLevelKey)
{
  expectError(kBase + "spacin: 0.02\n", "spacin", "unknown key (did you mean 'spacing'?)");
}

TEST(SceneLoader, UnknownNestedKey)
{
  expectError(kBase + "solver: {density_eror: 0.001}\n", "solver.density_eror", "unknown key");
  expectError(kBase + kBoundaries + "    motion: {angular_velocty: [0, 0, 1]}\n",
              "boundaries[1].motion.angular_velocty", "unknown key");
}

TEST(SceneLoader, MotionStartAndRamp)
{
  const SceneConfig s = parseScene(
      kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], start: 0.2, ramp: 0.1}\n", "scene.yaml");
  EXPECT_DOUBLE_EQ(s.boundaries[1].motion.start, 0.2);
  EXPECT_DOUBLE_EQ(s.boundaries[1].motion.ramp, 0.1);
  EXPECT_DOUBLE_EQ(s.boundaries[0].motion.start, 0.0);  // defaults
  EXPECT_DOUBLE_EQ(s.boundaries[0].motion.ramp, 0.0);
  expectError(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], start: -0.2}\n",
              "boundaries[1].motion.start", "must be >= 0");
  expectError(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], ramp: -0.1}\n",
              "boundaries[1].motion.ramp", "must be >= 0");
  expectError(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], ramp: .nan}\n",
              "boundaries[1].motion.ramp", "");
  expectError(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], rampe: 0.1}\n",
              "boundaries[1].motion.rampe", "unknown key (did you mean 'ramp'?)");
  expectError(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1], strat: 0.1}\n",
              "boundaries[1].motion.strat", "unknown key (did you mean 'start'?)");
}

TEST(SceneLoader, SampleSpacingAutoZeroOrGiven)
{
  // Default: the scene's spacing, moving or not.
  const SceneConfig a = parseScene(kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1]}\n", "scene.yaml");
  EXPECT_EQ(a.boundaries[1].sample_spacing, 0.0);
  EXPECT_DOUBLE_EQ(sampleSpacing(a.boundaries[1], a.spacing), a.spacing);
  // `auto`: half the spacing for a body that moves, the spacing for a still one.
  const SceneConfig b = parseScene(
      kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1]}\n    sample_spacing: auto\n", "scene.yaml");
  EXPECT_EQ(b.boundaries[1].sample_spacing, kAutoSampleSpacing);
  EXPECT_DOUBLE_EQ(sampleSpacing(b.boundaries[1], b.spacing), 0.5 * b.spacing);  // the turning ball
  const SceneConfig still = parseScene(kBase + kBoundaries + "    sample_spacing: auto\n", "scene.yaml");
  EXPECT_DOUBLE_EQ(sampleSpacing(still.boundaries[1], still.spacing), still.spacing);
  // 0 given: the scene's spacing; a number: that.
  const SceneConfig c = parseScene(
      kBase + kBoundaries + "    motion: {angular_velocity: [0, 0, 1]}\n    sample_spacing: 0\n", "scene.yaml");
  EXPECT_DOUBLE_EQ(sampleSpacing(c.boundaries[1], c.spacing), c.spacing);
  const SceneConfig d = parseScene(kBase + kBoundaries + "    sample_spacing: 0.01\n", "scene.yaml");
  EXPECT_DOUBLE_EQ(sampleSpacing(d.boundaries[1], d.spacing), 0.01);
  expectError(kBase + kBoundaries + "    sample_spacing: fine\n", "boundaries[1].sample_spacing", "");
  expectError(kBase + kBoundaries + "    sample_spacing: -1\n", "boundaries[1].sample_spacing", "must be >= 0 or auto");
}

TEST(SceneLoader, DuplicateKey)
{
  expectError(kBase + "rest_density: 1000\nrest_density: 998\n", "rest_density", "duplicate key");
}

TEST(SceneLoader, WrongType)
{
  expectError(kBase + "rest_density: heavy\n", "rest_density", "expected a number, got 'heavy'");
  expectError(kBase + "gravity: [0, -9.81]\n", "gravity", "expected a 3-vector");
  expectError(kBase + "gravity: [0, 0, down]\n", "gravity[2]", "expected a number");
  expectError(kBase + "solver: {max_iterations: 2.5}\n", "solver.max_iterations", "expected an integer");
  expectError(kBase + "solver: {warm_start: maybe}\n", "solver.warm_start", "expected true or false");
  expectError(kBase + "solver: 3\n", "solver", "expected a map");
  expectError(kBase + "boundaries: {tank: 1}\n", "boundaries", "expected a list");
}

TEST(SceneLoader, FillKeysAreCheckedAndNamed)
{
  const SceneConfig defaults = parseScene(kBase, "scene.yaml");
  EXPECT_TRUE(defaults.fill.trim);  // on unless turned off
  EXPECT_TRUE(defaults.fill.relax);
  expectError(kBase + "fill: {trimm: false}\n", "fill.trimm", "unknown key");
  expectError(kBase + "fill: {relax: sometimes}\n", "fill.relax", "expected true or false");
  expectError(kBase + "fill: {relax_tolerance: 0}\n", "fill.relax_tolerance", "must be in (0, 1)");
  expectError(kBase + "fill: {relax_max_steps: -1}\n", "fill.relax_max_steps", "must be in [0, 10000]");
  const SceneConfig off = parseScene(kBase, "scene.yaml", {"fill.relax=false"});
  EXPECT_FALSE(off.fill.relax);
}

TEST(SceneLoader, NegativeSpacing)
{
  expectError("spacing: -0.01\n" + kBase.substr(kBase.find("domain")), "spacing", "must be > 0");
}

TEST(SceneLoader, FluidBlockOutsideDomain)
{
  expectError("domain: {min: [0, 0, 0], max: [1, 1, 1]}\nfluid:\n  - box: {min: [0.5, 0.5, 0.5], max: [1.5, 1, 1]}\n",
              "fluid[0].box", "outside the domain");
}

TEST(SceneLoader, EmptyFluidList)
{
  expectError("domain: {min: [0, 0, 0], max: [1, 1, 1]}\nfluid: []\n", "fluid", "no fluid block");
}

TEST(SceneLoader, MissingRequiredKey)
{
  expectError(kBase + "boundaries:\n  - sphere: {center: [0.7, 0.7, 0.7]}\n", "boundaries[0].sphere.radius", "missing");
}

TEST(SceneLoader, ExactlyOneShapeKey)
{
  expectError(kBase +
                  "boundaries:\n  - box: {min: [0, 0, 0], max: [1, 1, 1]}\n    sphere: {center: [0, 0, 0], "
                  "radius: 0.1}\n",
              "boundaries[0]", "two shape keys");
  expectError(kBase + "boundaries:\n  - name: nothing\n    inside: true\n", "boundaries[0]", "needs a shape");
}

TEST(SceneLoader, UnknownEnumValue)
{
  expectError(kBase + "solver: {boundary_pressure: mirror}\n", "solver.boundary_pressure",
              "unknown value 'mirror' (expected mirroring, mirroring_eq2, sph or mls)");
  expectError(kBase + "viscosity: {model: laminar}\n", "viscosity.model", "expected none, artificial or xsph");
  expectError(kBase + "solver: {mls_singular: ignore}\n", "solver.mls_singular",
              "expected fallback, pseudo_inverse or regularized");
  expectError(kBase + "solver: {cold_start: hot}\n", "solver.cold_start",
              "unknown value 'hot' (expected zero or jacobi)");
  expectError(kBase + "solver: {warm_start_guess: last}\n", "solver.warm_start_guess",
              "unknown value 'last' (expected previous or damped)");
  expectError(kBase + "solver: {sweep: sor}\n", "solver.sweep",
              "unknown value 'sor' (expected jacobi or gauss_seidel)");
  // Chebyshev's semi-iteration extrapolates Jacobi sweeps (Eq. A8a): not with Gauss-Seidel's.
  expectError(kBase + "solver: {sweep: gauss_seidel, chebyshev_rho: 0.95}\n", "solver.chebyshev_rho",
              "cannot be combined with solver.sweep: gauss_seidel");
}

TEST(SceneLoader, SweepOrder)
{
  EXPECT_EQ(parseScene(kBase, "scene.yaml").solver.sweep, SweepOrder::Jacobi);  // the paper's, the default
  EXPECT_EQ(parseScene(kBase + "solver: {sweep: gauss_seidel}\n", "scene.yaml").solver.sweep, SweepOrder::GaussSeidel);
  EXPECT_EQ(parseScene(kBase, "scene.yaml", {"solver.sweep=gauss_seidel"}).solver.sweep, SweepOrder::GaussSeidel);
}

TEST(SceneLoader, TimeStepIsFixedOrAdaptive)
{
  expectError(kBase + "time_step: {fixed: 0.001, cfl: 0.4}\n", "time_step", "either fixed or cfl");
  expectError(kBase + "time_step: {fixed: 0.001, max: 0.01}\n", "time_step.max", "only with time_step.cfl");
}

TEST(SceneLoader, MissingMeshFileIsAnError)
{
  expectError(kBase + "boundaries:\n  - mesh: {file: part.stl}\n", "boundaries[0].mesh.file", "part.stl: no such file");
}

TEST(SceneLoader, OffsetOnlyForMeshes)
{
  expectError(kBase + kBoundaries + "    offset: none\n", "boundaries[1].offset", "only mesh boundaries");
}

TEST(SceneLoader, OverrideChangesValues)
{
  const SceneConfig s = parseScene(kBase + kBoundaries, "scene.yaml",
                                   {"solver.boundary_pressure=sph", "gravity=[0,0,-1]", "spacing=0.04",
                                    "viscosity.model=artificial", "boundaries[0].inside=false"});
  EXPECT_EQ(s.solver.boundary_pressure, BoundaryPressureMethod::SphExtrapolation);
  EXPECT_TRUE(s.gravity.isApprox(Vec3d(0, 0, -1)));
  EXPECT_DOUBLE_EQ(s.spacing, 0.04);
  EXPECT_EQ(s.viscosity.model, ViscosityModel::Artificial);  // a section absent from the file
  EXPECT_FALSE(s.boundaries[0].inside);
}

TEST(SceneLoader, OverrideListIndex)
{
  const SceneConfig s =
      parseScene(kBase + kBoundaries, "scene.yaml", {"boundaries[1].sphere.radius=0.2", "fluid[0].box.max[2]=0.6"});
  EXPECT_DOUBLE_EQ(s.boundaries[1].sphere.radius, 0.2);
  EXPECT_DOUBLE_EQ(s.fluid[0].box.max.z(), 0.6);
  expectError(kBase + kBoundaries, "boundaries[5]", "index out of range", {"boundaries[5].sphere.radius=0.2"});
}

TEST(SceneLoader, OverrideOfUnknownKeyIsAnError)
{
  expectError(kBase, "solver.density_eror", "unknown key", {"solver.density_eror=0.01"});
  expectError(kBase, "solver.density_eror", "--set solver.density_eror=0.01", {"solver.density_eror=0.01"});
  expectError(kBase, "spacing", "not a map", {"spacing.x=1"});
  expectError(kBase, "", "expected key.path=value", {"spacing"});
  expectError(kBase, "fluid[0", "malformed key path", {"fluid[0=1"});
}

TEST(SceneLoader, OverrideValueIsChecked)
{
  expectError(kBase, "spacing", "expected a number, got 'fine' (after --set spacing=fine)", {"spacing=fine"});
  expectError(kBase, "spacing", "must be > 0", {"spacing=-1"});
}

TEST(SceneLoader, OverrideSwitchesTimeStepMode)
{
  const std::string adaptive = kBase + "time_step: {cfl: 0.4, min: 1.0e-5, max: 0.005}\n";
  const SceneConfig fixed = parseScene(adaptive, "scene.yaml", {"time_step.fixed=0.002"});
  EXPECT_FALSE(fixed.time_step.adaptive);
  EXPECT_DOUBLE_EQ(fixed.time_step.fixed, 0.002);

  const SceneConfig back = parseScene(kBase + "time_step: {fixed: 0.001}\n", "scene.yaml", {"time_step.cfl=0.3"});
  EXPECT_TRUE(back.time_step.adaptive);
  EXPECT_DOUBLE_EQ(back.time_step.cfl, 0.3);

  const SceneConfig whole = parseScene(adaptive, "scene.yaml", {"time_step={fixed: 0.003}"});
  EXPECT_FALSE(whole.time_step.adaptive);
  EXPECT_DOUBLE_EQ(whole.time_step.fixed, 0.003);
}

TEST(MeshTopology, ClosedOpenAndOrientation)
{
  TriangleMesh tetra;
  tetra.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)};
  tetra.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};  // outward
  EXPECT_TRUE(io::isClosedMesh(tetra));
  EXPECT_NEAR(io::signedVolume(tetra), 1.0 / 6.0, 1e-12);

  TriangleMesh inward = tetra;
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  EXPECT_LT(io::signedVolume(inward), 0.0);
  EXPECT_TRUE(io::orientOutward(inward));
  EXPECT_NEAR(io::signedVolume(inward), 1.0 / 6.0, 1e-12);

  TriangleMesh open = tetra;
  open.triangles.pop_back();
  EXPECT_FALSE(io::isClosedMesh(open));
  EXPECT_FALSE(io::orientOutward(open));

  TriangleMesh inconsistent = tetra;
  std::swap(inconsistent.triangles[0][1], inconsistent.triangles[0][2]);
  EXPECT_FALSE(io::isClosedMesh(inconsistent));
}

TEST(MeshTopology, CadSeamsSliversFlippedFacesAndPartsMeetingAtAnEdge)
{
  // What CAD exports bring: each used to make a closed mesh "open" (a tank lost a fifth of its
  // water to the fill's outside test, a solid block kept water inside it).
  TriangleMesh tetra;
  tetra.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)};
  tetra.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};  // outward

  TriangleMesh flipped = tetra;  // one face wound against its neighbours: turned to match
  std::swap(flipped.triangles[2][1], flipped.triangles[2][2]);
  EXPECT_TRUE(io::orientOutward(flipped));
  EXPECT_TRUE(io::isClosedMesh(flipped));
  EXPECT_NEAR(io::signedVolume(flipped), 1.0 / 6.0, 1e-12);

  TriangleMesh sliver = tetra;  // a zero-area triangle along an edge
  sliver.vertices.push_back(Vec3d(0.5, 0, 0));
  sliver.triangles.push_back({0, 4, 1});
  EXPECT_TRUE(io::isClosedMesh(sliver));
  EXPECT_EQ(io::borderEdges(sliver), 0u);

  TriangleMesh seam = tetra;  // one face on a copy of a corner 1e-7 away (float rounding)
  seam.vertices.push_back(Vec3d(0, 0, 1 + 1e-7));
  seam.triangles[3] = {1, 2, 4};
  EXPECT_TRUE(io::isClosedMesh(seam));
  seam.vertices.back().z() = 1 + 5e-5;  // a seam between faces exported apart: 3e-5 of the diagonal
  EXPECT_TRUE(io::isClosedMesh(seam));
  EXPECT_EQ(io::borderEdges(seam), 0u);
  seam.vertices.back().z() = 1.001;  // a real gap (1e-3 of the size) stays one
  EXPECT_FALSE(io::isClosedMesh(seam));
  EXPECT_EQ(io::borderEdges(seam), 4u);  // the moved face's two new edges, and the two it left

  TriangleMesh pair = tetra;  // two tetrahedra sharing the edge 1-2, the second inside out
  for (const Vec3d& v : {Vec3d(1, 1, 0), Vec3d(1, 1, -1)}) pair.vertices.push_back(v);
  for (std::array<int, 3> t : {std::array<int, 3>{1, 2, 4}, {1, 4, 5}, {1, 5, 2}, {2, 5, 4}})
    pair.triangles.push_back(t);
  EXPECT_TRUE(io::orientOutward(pair));
  EXPECT_TRUE(io::isClosedMesh(pair));
  EXPECT_NEAR(io::signedVolume(pair), 2.0 / 6.0, 1e-12);  // each part outward, not one flipped for the other
}

TEST(SceneLoader, InlineMeshIsOrientedAndClassified)
{
  const std::string scene = kBase + R"yaml(
boundaries:
  - name: inward_tetra
    mesh:
      vertices: [[0.6, 0.6, 0.6], [0.9, 0.6, 0.6], [0.6, 0.9, 0.6], [0.6, 0.6, 0.9]]
      triangles: [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]
  - name: paddle
    mesh:
      vertices: [[0.6, 0.6, 0.6], [0.9, 0.6, 0.6], [0.6, 0.9, 0.6]]
      triangles: [[0, 1, 2]]
)yaml";
  const SceneConfig s = parseScene(scene, "scene.yaml");
  EXPECT_TRUE(s.boundaries[0].mesh_closed);
  EXPECT_GT(io::signedVolume(s.boundaries[0].mesh), 0.0);
  EXPECT_FALSE(s.boundaries[1].mesh_closed);
  // An open inline mesh used as a solid is warned about as a file's is (it was not), and not when
  // `offset: none` says the thin shell is meant.
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("boundaries[1] 'paddle' (inline mesh): not a closed surface (3 border edges)"),
            std::string::npos)
      << s.warnings[0];
  EXPECT_TRUE(parseScene(scene + "    offset: none\n", "scene.yaml").warnings.empty());
  // inside: true on it did nothing, silently: now said.
  const SceneConfig held = parseScene(scene + "    offset: none\n    inside: true\n", "scene.yaml");
  ASSERT_EQ(held.warnings.size(), 1u);
  EXPECT_NE(held.warnings[0].find("boundaries[1] 'paddle': inside: true on an open mesh does nothing"),
            std::string::npos)
      << held.warnings[0];
}

}  // namespace
TEST(SceneLoader, NonFinitePoseIsAnErrorNamingKeyAndValue)
{
  // Only translations were checked: a NaN angle made the rotation NaN and the body vanished.
  expectError(
      kBase + "boundaries:\n  - sphere: {center: [0.7, 0.7, 0.7], radius: 0.1}\n    pose: {rpy: [.nan, 0, 0]}\n",
      "boundaries[0].pose.rpy", "must be finite, got [nan, 0, 0]");
  expectError(
      kBase + "boundaries:\n  - sphere: {center: [0.7, 0.7, 0.7], radius: 0.1}\n    pose: {rpy: [0, .inf, 0]}\n",
      "boundaries[0].pose.rpy", "got [0, inf, 0]");
  expectError(
      kBase + "boundaries:\n  - sphere: {center: [0.7, 0.7, 0.7], radius: 0.1}\n    pose: {xyz: [0, 0, .nan]}\n",
      "boundaries[0].pose.xyz", "must be finite");
  // Through --set as well.
  expectError(kBase + "boundaries:\n  - sphere: {center: [0.7, 0.7, 0.7], radius: 0.1}\n    pose: {rpy: [0, 0, 0]}\n",
              "boundaries[0].pose.rpy", "must be finite", {"boundaries[0].pose.rpy=[0, 0, .nan]"});
}

TEST(SceneLoader, FluidParticleBudgetIsAKey)
{
  // kBase: a 0.4 m cube at 5 cm, 512 lattice points.
  expectError("max_fluid_particles: 500\n" + kBase, "fluid",
              "512 fluid particles at spacing 0.05 m, more than max_fluid_particles = 500");
  EXPECT_EQ(errorOf("max_fluid_particles: 512\n" + kBase), "");
  expectError("max_fluid_particles: 0\n" + kBase, "max_fluid_particles", "whole number >= 1");
}

}  // namespace fluid_sim

namespace fluid_sim
{
namespace
{
const std::string kInstruments = R"yaml(
regions:
  - name: cup
    box: {min: [0.1, 0.1, 0.1], max: [0.3, 0.3, 0.3]}
    pose: {xyz: [0.05, 0, 0], rpy: [0, 0, 1.5707963267948966]}
  - name: bowl
    sphere: {center: [0.5, 0.5, 0.2], radius: 0.1}
  - name: in_tank
    body: tank
probes:
  - name: p1
    position: [0.3, 0.3, 0.2]
spill: {below: 0.05}
)yaml";
}  // namespace

TEST(SceneLoader, InstrumentKeys)
{
  const SceneConfig s = parseScene(kBase + kInstruments, "scene.yaml");
  ASSERT_EQ(s.regions.size(), 3u);
  EXPECT_EQ(s.regions[0].name, "cup");
  EXPECT_EQ(s.regions[0].shape, RegionShape::Box);
  EXPECT_TRUE(s.regions[0].box.max.isApprox(Vec3d(0.3, 0.3, 0.3)));
  EXPECT_TRUE(s.regions[0].pose.apply(Vec3d(1, 0, 0)).isApprox(Vec3d(0.05, 1, 0), 1e-12));
  EXPECT_EQ(s.regions[1].name, "bowl");
  EXPECT_EQ(s.regions[1].shape, RegionShape::Sphere);
  EXPECT_DOUBLE_EQ(s.regions[1].sphere.radius, 0.1);
  EXPECT_EQ(s.regions[2].shape, RegionShape::Body);
  EXPECT_EQ(s.regions[2].body, "tank");  // the loader does not know the bodies a node adds
  ASSERT_EQ(s.probes.size(), 1u);
  EXPECT_EQ(s.probes[0].name, "p1");
  EXPECT_TRUE(s.probes[0].position.isApprox(Vec3d(0.3, 0.3, 0.2)));
  EXPECT_TRUE(s.spill.enabled);
  EXPECT_DOUBLE_EQ(s.spill.below, 0.05);

  // None of them by default.
  const SceneConfig plain = parseScene(kBase, "scene.yaml");
  EXPECT_TRUE(plain.regions.empty());
  EXPECT_TRUE(plain.probes.empty());
  EXPECT_FALSE(plain.spill.enabled);
}

TEST(SceneLoader, BadInstrumentKeysAreNamed)
{
  const std::string scene = kBase + kInstruments;
  expectError(scene, "regions[1].sphere.radius", "must be > 0", {"regions[1].sphere.radius=0"});
  expectError(scene, "regions[1].name", "duplicate name 'cup'", {"regions[1].name=cup"});
  expectError(scene, "regions[0].name", "no valid ROS name", {"regions[0].name=my cup"});
  expectError(scene, "regions[0].box", "max must exceed min", {"regions[0].box.max=[0.1, 0.3, 0.3]"});
  expectError(scene, "probes[0].name", "no valid ROS name", {"probes[0].name=p-1"});
  expectError(scene, "probes[0].position", "", {"probes[0].position=[1, 2]"});
  expectError(scene, "spill.below", "", {"spill.below=high"});
  expectError(kBase + "regions:\n  - {box: {min: [0, 0, 0], max: [1, 1, 1]}}\n", "regions[0].name", "missing");
  expectError(kBase + "regions:\n  - {name: a}\n", "regions[0]", "needs a shape: box, sphere or body");
  expectError(kBase +
                  "regions:\n  - {name: a, box: {min: [0, 0, 0], max: [1, 1, 1]}, "
                  "sphere: {center: [0, 0, 0], radius: 1}}\n",
              "regions[0]", "has two shapes, 'box' and 'sphere'");
  expectError(kBase + "regions:\n  - {name: a, body: tank, pose: {xyz: [0, 0, 0]}}\n", "regions[0].pose",
              "only a box region");
  expectError(kBase + "regions:\n  - {name: a, body: ''}\n", "regions[0].body", "must name a boundary body");
  expectError(kBase + "regions:\n  - {name: a, sphere: {center: [0, 0, 0], radius: 1}, pose: {xyz: [0, 0, 0]}}\n",
              "regions[0].pose", "only a box region");
  expectError(kBase + "probes:\n  - {name: a, positon: [0, 0, 0]}\n", "probes[0].positon", "unknown key");
  expectError(kBase + "spill: {}\n", "spill.below", "missing");
}

// ------------------------------------------------------------------------------ free bodies

TEST(SceneLoader, DynamicKeysAndContactDefaults)
{
  const SceneConfig s = parseScene(kBase + kBoundaries + "    dynamic: {density: 500}\n", "scene.yaml");
  ASSERT_EQ(s.boundaries.size(), 2u);
  const DynamicConfig& d = s.boundaries[1].dynamic;
  EXPECT_TRUE(d.enabled);
  EXPECT_DOUBLE_EQ(d.density, 500.0);
  EXPECT_DOUBLE_EQ(d.mass, 0.0);
  EXPECT_FALSE(d.inertia.has_value());  // from the shape (core)
  EXPECT_FALSE(d.center_of_mass.has_value());
  EXPECT_TRUE(d.linear_velocity.isZero());
  EXPECT_TRUE(d.angular_velocity.isZero());
  EXPECT_FALSE(s.boundaries[0].dynamic.enabled);

  const SceneConfig plain = parseScene(kBase + kBoundaries, "scene.yaml");
  EXPECT_FALSE(plain.boundaries[1].dynamic.enabled);
  EXPECT_DOUBLE_EQ(plain.contacts.friction, ContactConfig().friction);
  EXPECT_DOUBLE_EQ(parseScene(kBase + "contacts: {friction: 0}\n", "scene.yaml").contacts.friction, 0.0);
  // Bullet's contacts by default; the particle contacts by name.
  EXPECT_EQ(plain.contacts.model, ContactModel::Bullet);
  EXPECT_EQ(parseScene(kBase + "contacts: {model: particles}\n", "scene.yaml").contacts.model, ContactModel::Particles);
  EXPECT_EQ(parseScene(kBase + "contacts: {model: bullet, friction: 0.3}\n", "scene.yaml").contacts.model,
            ContactModel::Bullet);
  EXPECT_DOUBLE_EQ(plain.contacts.rolling_resistance, 0.01);
  EXPECT_DOUBLE_EQ(parseScene(kBase + "contacts: {rolling_resistance: 0}\n", "scene.yaml").contacts.rolling_resistance,
                   0.0);
}

TEST(SceneLoader, BadDynamicAndContactKeysAreNamed)
{
  const std::string ball = kBase + kBoundaries;
  expectError(ball + "    dynamic: {density: 500, densty: 600}\n", "boundaries[1].dynamic.densty",
              "unknown key (did you mean 'density'?) (line 13)");
  expectError(ball + "    dynamic: {density: 500, spin: [0, 0, 1]}\n", "boundaries[1].dynamic.spin", "unknown key");
  expectError(ball + "    dynamic: {mass: 1, inertia: [1, 1, 1]}\n", "boundaries[1].dynamic.inertia",
              "expected 6 numbers [ixx, iyy, izz, ixy, ixz, iyz], got a list of 3 (line 13)");
  expectError(ball + "    dynamic: {mass: 1, inertia: [1, 1, 1, 0, 0, x]}\n", "boundaries[1].dynamic.inertia[5]",
              "expected a number");
  expectError(ball + "    dynamic: {density: 500, center_of_mass: [0, 0]}\n", "boundaries[1].dynamic.center_of_mass",
              "expected a 3-vector");
  expectError(ball + "    dynamic: {density: 500, linear_velocity: fast}\n", "boundaries[1].dynamic.linear_velocity",
              "expected a 3-vector");
  expectError(ball + "    dynamic: {density: heavy}\n", "boundaries[1].dynamic.density", "expected a number");
  expectError(ball + "    dynamic: 500\n", "boundaries[1].dynamic", "expected a map");
  // Exactly one of density and mass, and physical values, are core's validate().
  expectError(ball + "    dynamic: {density: 500, mass: 1}\n", "boundaries[1].dynamic", "exactly one");
  expectError(ball + "    dynamic: {}\n", "boundaries[1].dynamic", "exactly one");
  expectError(kBase + "contacts: {frction: 0.2}\n", "contacts.frction", "did you mean 'friction'");
  expectError(kBase + "contacts: {friction: slippery}\n", "contacts.friction", "expected a number");
  expectError(kBase + "contacts: {friction: -1}\n", "contacts.friction", "must be finite and >= 0");
  expectError(kBase + "contacts: {model: ode}\n", "contacts.model", "bullet");
  expectError(kBase + "contacts: {rolling_resistance: -0.1}\n", "contacts.rolling_resistance",
              "must be finite and >= 0, got -0.1");
}

namespace
{
// Two links with collision geometry and one without, for free_links.
const char* const kBoatUrdf = R"(<robot name="boat">
  <link name="hull"><collision><geometry><box size="0.2 0.1 0.1"/></geometry></collision></link>
  <link name="mast"><collision><origin xyz="0 0 0.1"/><geometry><sphere radius="0.03"/></geometry></collision></link>
  <link name="flag"/>
  <joint name="mast_mount" type="fixed"><parent link="hull"/><child link="mast"/></joint>
  <joint name="flag_mount" type="fixed"><parent link="mast"/><child link="flag"/></joint>
</robot>)";

/// kBase with one urdf entry reading `urdf` (an absolute path), with the given extra keys inside
/// the urdf map (YAML lines indented 6).
std::string boatScene(const std::string& urdf, const std::string& urdf_keys)
{
  return kBase + "boundaries:\n  - urdf:\n      file: " + urdf + "\n" + urdf_keys +
         "    pose: {xyz: [0.7, 0.7, 0.7]}\n";
}
}  // namespace

TEST(SceneLoader, UrdfFreeLinks)
{
  test::TempDir dir;
  const std::string urdf = dir.write("boat.urdf", kBoatUrdf);
  const SceneConfig s = parseScene(boatScene(urdf,
                                             "      free_links:\n"
                                             "        hull: {density: 500, linear_velocity: [0, 0, -0.1]}\n"),
                                   "scene.yaml");
  ASSERT_EQ(s.boundaries.size(), 2u);
  const auto byName = [&](const std::string& name) -> const BoundaryConfig& {
    return *std::find_if(s.boundaries.begin(), s.boundaries.end(),
                         [&](const BoundaryConfig& b) { return b.name == name; });
  };
  const BoundaryConfig& hull = byName("hull");
  EXPECT_TRUE(hull.dynamic.enabled);
  EXPECT_DOUBLE_EQ(hull.dynamic.density, 500.0);
  EXPECT_TRUE(hull.dynamic.linear_velocity.isApprox(Vec3d(0, 0, -0.1)));
  EXPECT_FALSE(byName("mast").dynamic.enabled);

  // An empty map frees nothing.
  for (const auto& b : parseScene(boatScene(urdf, "      free_links: {}\n"), "scene.yaml").boundaries)
    EXPECT_FALSE(b.dynamic.enabled) << b.name;

  expectError(boatScene(urdf, "      free_links: {keel: {density: 500}}\n"), "boundaries[0].urdf.free_links.keel",
              "unknown link 'keel' in " + urdf + " (links: ");
  expectError(boatScene(urdf, "      links: [mast]\n      free_links: {hull: {density: 500}}\n"),
              "boundaries[0].urdf.free_links.hull", "link 'hull' in " + urdf + " is not one of this entry's bodies");
  expectError(boatScene(urdf, "      free_links: {flag: {mass: 1}}\n"), "boundaries[0].urdf.free_links.flag",
              "without collision geometry; bodies: hull or mast) (line 9)");
  expectError(boatScene(urdf, "      free_links: {hull: {desnity: 500}}\n"),
              "boundaries[0].urdf.free_links.hull.desnity", "did you mean 'density'");
  expectError(boatScene(urdf, "      free_links: [hull]\n"), "boundaries[0].urdf.free_links", "expected a map");
  expectError(boatScene(urdf, "      free_links: {hull: {density: 500, mass: 2}}\n"),
              "boundaries[0].urdf.free_links.hull",
              "exactly one of density (kg/m^3) and mass (kg), > 0, for 'hull', got density 500, mass 2");
  expectError(boatScene(urdf, "") + "    dynamic: {density: 500}\n", "boundaries[0].dynamic", "urdf.free_links");
  // The entry's motion applies to every link, the free one too: named at its free_links key
  // (it was "boundaries[4].dynamic" for a scene with two entries).
  expectError(
      boatScene(urdf, "      free_links: {hull: {density: 500}}\n") + "    motion: {linear_velocity: [0.1, 0, 0]}\n",
      "boundaries[0].urdf.free_links.hull", "'hull' has a scripted motion; it cannot also be free");
  // Messages name the scene's entry, not a body's index among the links before it: the mast's
  // bad sample spacing is boundaries[1], the second entry, though the boat's hull comes first.
  const std::string two = kBase + "boundaries:\n  - urdf:\n      file: " + urdf +
                          "\n    pose: {xyz: [0.7, 0.7, 0.7]}\n  - name: ball\n    sphere: {center: [0.3, 0.3, 0.3], "
                          "radius: 0.1}\n    sample_spacing: 0.5\n";
  expectError(two, "boundaries[1].sample_spacing", "must not exceed");
}

TEST(SceneLoader, UrdfThinLinksAreMeantAsThinShellsOneByOne)
{
  // A paddle blade made as one sheet is meant as a thin shell; the entry's offset: none would say
  // so for every link (putting a closed link's layer on its surface too), thin_links for the
  // blade alone. It was warned about on every run of the demo.
  test::TempDir dir;
  dir.write("blade.obj", "v 0 -0.05 0\nv 0 0.05 0\nv 0 0.05 -0.1\nv 0 -0.05 -0.1\nf 1 2 3\nf 1 3 4\n");
  dir.write("arm.obj",  // a closed tetrahedron: a mesh, not a primitive
            "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  const std::string urdf = dir.write("robot.urdf", R"(<robot name="stirrer">
  <link name="arm"><collision><geometry><mesh filename="arm.obj"/></geometry></collision></link>
  <link name="blade"><collision><geometry><mesh filename="blade.obj"/></geometry></collision></link>
  <link name="tip"/>
  <joint name="wrist" type="fixed"><parent link="arm"/><child link="blade"/><origin xyz="0 0 -0.05"/></joint>
  <joint name="end" type="fixed"><parent link="blade"/><child link="tip"/></joint>
</robot>)");
  const auto byName = [](const SceneConfig& s, const std::string& name) -> const BoundaryConfig& {
    return *std::find_if(s.boundaries.begin(), s.boundaries.end(),
                         [&](const BoundaryConfig& b) { return b.name == name; });
  };
  const auto openWarnings = [](const SceneConfig& s) {
    return std::count_if(s.warnings.begin(), s.warnings.end(),
                         [](const std::string& w) { return w.find("not a closed surface") != std::string::npos; });
  };
  const SceneConfig plain = parseScene(boatScene(urdf, "      links: [arm, blade]\n"), "scene.yaml");
  EXPECT_EQ(openWarnings(plain), 1);
  const SceneConfig thin =
      parseScene(boatScene(urdf, "      links: [arm, blade]\n      thin_links: [blade]\n"), "scene.yaml");
  EXPECT_EQ(openWarnings(thin), 0);
  EXPECT_EQ(byName(thin, "blade").mesh_offset, SurfaceOffset::None);
  EXPECT_EQ(byName(thin, "arm").mesh_offset, SurfaceOffset::Auto);  // the closed link keeps its offset
  EXPECT_TRUE(byName(thin, "arm").mesh_closed);
  // The entry's offset: none still applies to every link.
  const SceneConfig all =
      parseScene(boatScene(urdf, "      thin_links: [blade]\n") + "    offset: none\n", "scene.yaml");
  EXPECT_EQ(byName(all, "arm").mesh_offset, SurfaceOffset::None);

  expectError(boatScene(urdf, "      thin_links: [blad]\n"), "boundaries[0].urdf.thin_links[0]",
              "unknown link 'blad' in " + urdf + " (links: ");
  expectError(boatScene(urdf, "      thin_links: [blade, blade]\n"), "boundaries[0].urdf.thin_links[1]",
              "link 'blade' is listed twice");
  expectError(boatScene(urdf, "      links: [arm]\n      thin_links: [blade]\n"), "boundaries[0].urdf.thin_links[0]",
              "link 'blade' in " + urdf + " is not one of this entry's bodies");
  expectError(boatScene(urdf, "      thin_links: [tip]\n"), "boundaries[0].urdf.thin_links[0]",
              "without collision geometry; bodies: arm or blade)");
  expectError(boatScene(urdf, "      thin_links: blade\n"), "boundaries[0].urdf.thin_links", "expected a list");
}

TEST(SceneLoader, MirroringAtACflAbove0_2IsWarnedAbout)
{
  // Water at 2-3 m/s along a floor crossed a box tank's end wall with mirroring at cfl 0.4 (7 of
  // 8 dam breaks), at 0.2 in none.
  const auto warned = [](const SceneConfig& s) {
    return std::any_of(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
      return w.find("solver.boundary_pressure mirroring with time_step.cfl 0.4: fast water") != std::string::npos;
    });
  };
  const std::vector<std::string> mirroring = {"solver.boundary_pressure=mirroring", "time_step={cfl: 0.4}"};
  EXPECT_TRUE(warned(parseScene(kBase, "scene.yaml", mirroring)));
  EXPECT_FALSE(warned(parseScene(kBase, "scene.yaml", {"solver.boundary_pressure=mirroring", "time_step={cfl: 0.2}"})));
  EXPECT_FALSE(warned(parseScene(kBase, "scene.yaml", {"solver.boundary_pressure=mls", "time_step={cfl: 0.4}"})));
  EXPECT_FALSE(warned(parseScene(kBase, "scene.yaml", {"solver.boundary_pressure=mirroring"})));  // a fixed step
}

TEST(SceneLoader, ImpossibleMotionsViscosityAndVelocitiesAreNamed)
{
  const std::string plate =
      kBase + "boundaries:\n  - name: plate\n    box: {min: [0.6, 0.6, 0.6], max: [0.7, 0.7, 0.8]}\n";
  // A body posed from outside cannot also follow a script (the script was ignored).
  expectError(plate + "    external: true\n    motion: {linear_velocity: [0.5, 0, 0]}\n", "boundaries[0].motion",
              "posed from outside (external: true); it cannot also have a scripted motion");
  // Faster than sound in water: a slip (1e300 rad/s made the body vanish from the water).
  expectError(plate + "    motion: {angular_velocity: [0, 0, 1e300]}\n", "boundaries[0].motion",
              "faster than sound in water");
  expectError(plate + "    motion: {angular_velocity: [0, 0, 20000], about: [0.65, 0.65, 0.7]}\n",
              "boundaries[0].motion", "faster than sound in water");
  EXPECT_EQ(errorOf(plate + "    motion: {angular_velocity: [0, 0, 200], about: [0.65, 0.65, 0.7]}\n"), "");
  expectError(kBase, "fluid[0].velocity", "faster than sound in water", {"fluid[0].velocity=[1e30, 0, 0]"});
  // Viscosity coefficients without a model did nothing, silently; with model none they are kept
  // (a scene's viscosity switched off for a comparison).
  expectError(kBase + "viscosity: {coefficient: 0.05}\n", "viscosity.coefficient",
              "has no effect without viscosity.model");
  expectError(kBase + "viscosity: {boundary: 0.05}\n", "viscosity.boundary", "has no effect without viscosity.model");
  EXPECT_EQ(errorOf(kBase + "viscosity: {model: none, coefficient: 0.05}\n"), "");
  EXPECT_EQ(errorOf(kBase + "viscosity: {coefficient: 0}\n"), "");
}

TEST(SceneLoader, SinksAreReadAsRegionsAndABodySinkIsRefused)
{
  const SceneConfig s =
      parseScene(kBase +
                     "sinks:\n"
                     "  - {name: drain, box: {min: [0, 0, 0], max: [0.1, 0.1, 0.05]}, pose: {xyz: [1, 0, 0]}}\n"
                     "  - {name: funnel, sphere: {center: [0, 0, -1], radius: 0.2}}\n",
                 "scene.yaml");
  ASSERT_EQ(s.sinks.size(), 2u);
  EXPECT_EQ(s.sinks[0].name, "drain");
  EXPECT_EQ(s.sinks[0].shape, RegionShape::Box);
  EXPECT_DOUBLE_EQ(s.sinks[0].pose.translation.x(), 1.0);
  EXPECT_EQ(s.sinks[1].shape, RegionShape::Sphere);
  EXPECT_DOUBLE_EQ(s.sinks[1].sphere.radius, 0.2);
  expectError(kBase + "sinks:\n  - {name: cup_drain, body: cup}\n", "sinks[0].body", "a sink is a box or a sphere");
  expectError(kBase + "sinks:\n  - {name: d, sphere: {center: [0.5, 0.5, 0.5], radius: 0.1}, pose: {xyz: [0, 0, 0]}}\n",
              "sinks[0].pose", "only a box sink has a pose (a sphere is placed by its center)");
  expectError(kBase + "sinks:\n  - {name: d, box: {min: [0, 0, 0], max: [1, 1, 1]}, radius: 2}\n", "sinks[0].radius",
              "unknown key");
}

TEST(SceneLoader, EmittersAreReadWithTheirNozzleDirectionAndBudget)
{
  const SceneConfig s = parseScene(
      kBase +
          "emitters:\n"
          "  - {name: tap, circle: {radius: 0.02}, pose: {xyz: [0.1, 0.2, 0.5]}, direction: [0, 0, -1],\n"
          "     flow_rate: 2.0e-4, start: 0.5, duration: 2}\n"
          "  - {name: hose, rectangle: {size: [0.04, 0.02]}, pose: {xyz: [0, 0, 1], rpy: [0, 1.5707963, 0]},\n"
          "     speed: 1.5, body: arm, max_particles: 5000}\n",
      "scene.yaml");
  ASSERT_EQ(s.emitters.size(), 2u);
  const EmitterConfig& tap = s.emitters[0];
  EXPECT_EQ(tap.name, "tap");
  EXPECT_EQ(tap.shape, NozzleShape::Circle);
  EXPECT_DOUBLE_EQ(tap.radius, 0.02);
  EXPECT_DOUBLE_EQ(tap.pose.translation.z(), 0.5);
  EXPECT_LT((tap.pose.rotation * Vec3d::UnitZ() - Vec3d(0, 0, -1)).norm(), 1e-12);  // +z along direction
  EXPECT_DOUBLE_EQ(tap.flow_rate, 2.0e-4);
  EXPECT_DOUBLE_EQ(tap.speed, 0.0);
  EXPECT_DOUBLE_EQ(tap.start, 0.5);
  EXPECT_DOUBLE_EQ(tap.duration, 2.0);
  const EmitterConfig& hose = s.emitters[1];
  EXPECT_EQ(hose.shape, NozzleShape::Rectangle);
  EXPECT_DOUBLE_EQ(hose.size.x(), 0.04);
  EXPECT_DOUBLE_EQ(hose.speed, 1.5);
  EXPECT_EQ(hose.body, "arm");
  EXPECT_EQ(hose.max_particles, 5000u);
  EXPECT_TRUE(std::isinf(hose.duration));                                          // no end
  EXPECT_LT((hose.pose.rotation * Vec3d::UnitZ() - Vec3d(1, 0, 0)).norm(), 1e-6);  // pitched onto +x
  expectError(kBase + "emitters:\n  - {name: t, speed: 1}\n", "emitters[0]", "needs a nozzle shape");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, rectangle: {size: [1, 1]}, speed: 1}\n",
              "emitters[0]", "two nozzle shapes");
  expectError(kBase +
                  "emitters:\n  - {name: t, circle: {radius: 0.01}, pose: {rpy: [0, 0, 1]}, direction: [1, 0, 0], "
                  "speed: 1}\n",
              "emitters[0].direction", "either pose.rpy or direction");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, direction: [0, 0, 0], speed: 1}\n",
              "emitters[0].direction", "non-zero");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, speed: 1, flow_rate: 1}\n", "emitters[0]",
              "both speed and flow_rate");
  // A 0 given is out of range, as a negative value is (it read as if none were given).
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, flow_rate: 0}\n", "emitters[0].flow_rate",
              "must be > 0, got 0");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, speed: 0.0}\n", "emitters[0].speed",
              "must be > 0, got 0");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, sped: 1}\n", "emitters[0].sped", "unknown key");
  expectError(kBase + "emitters:\n  - {name: t, circle: {radius: 0.01}, speed: 1, max_particles: 0.5}\n",
              "emitters[0].max_particles", "whole number");
}

}  // namespace fluid_sim
