// Case files: a TOML description of a run (geometry, material, method, time, boundary
// conditions, initial conditions, damping, output, exact solution), read with toml++
// and validated key by key. The key reference is docs/cases.md.
//
// Every problem is reported as "FILE:LINE:COLUMN: key = value is invalid: what is
// allowed" (or "FILE: --set key: ..." for command-line overrides); an unknown key names
// the nearest valid key. `load_case` collects every problem it can find and throws one
// CaseError holding them all.
#pragma once

#include "engine/elasticity.hpp"
#include "engine/taylor_sph.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/smoothing_kernels.hpp"

#include <cstdint>
#include <stdexcept>
#include <limits>
#include <string>
#include <vector>

namespace tsph {

/// Bad input in a case file or an override; what() holds every message, one per line.
class CaseError : public std::invalid_argument {
 public:
  explicit CaseError(const std::vector<std::string>& messages);
  const std::vector<std::string>& messages() const { return messages_; }

 private:
  std::vector<std::string> messages_;
};

/// A scalar function of time, scaled per component by a boundary's `value` vector.
struct TimeFunctionSpec {
  std::string type = "constant";  ///< constant | pulse | ramp | table
  double start = 0.0, end = 0.0;  ///< pulse and ramp
  std::vector<double> times, values;  ///< table
};

struct RegionSpec {
  std::string type;  ///< box | half_space | group | all
  std::vector<double> lower, upper;  ///< box
  std::vector<double> point, normal; ///< half_space
  std::int64_t group = 0;
};

struct BoundarySpec {
  std::string name;
  std::string type;  ///< fixed | free | velocity | traction
  std::vector<RegionSpec> regions;  ///< their union
  std::vector<double> value;  ///< Dim components (velocity in m/s, traction in Pa)
  TimeFunctionSpec time;
  std::string profile = "uniform";  ///< uniform | cantilever_shear
  /// velocity only: G, Dim x Dim row by row (empty: none); the condition prescribes
  /// v = value + G x (time constant) or v = f(t) G x (value zero), x the current position
  /// (engine/affine_motion.hpp).
  std::vector<double> velocity_gradient;
};

struct ProbeSpec {
  std::string name;
  std::vector<double> point;      ///< the nearest real particle (initial positions)
  std::int64_t particle = -1;     ///< or a particle id
};

struct VelocityWave {
  std::vector<double> amplitude, direction;
  double wavelength = 1.0, phase = 0.0;
};

/// [initial.profile] type = "cantilever_mode" or "twist": a beam's velocity field along an
/// axis from `origin` (the clamp) in direction `axis`, s = (x0 - origin) . axis / |axis|,
/// zero where s < 0 (behind the clamp).
struct VelocityShape {
  std::string type;               ///< cantilever_mode | twist
  std::vector<double> origin, axis;
  double length = 1.0;            ///< L (m)
  /// cantilever_mode: v = amplitude phi_n(s / L), phi_n the clamped-free mode n with
  /// phi_n(1) = 1 (engine/validation/plate.hpp), so `amplitude` is the tip's velocity.
  std::vector<double> amplitude;
  std::int64_t mode = 1;
  /// twist (3D): v = angular_velocity sin(pi s / (2 L)) a x (x0 - origin), a the unit axis.
  double angular_velocity = 0.0;
};

struct CaseFile {
  std::string path;       ///< the case file as given
  std::string directory;  ///< its directory (particle files are relative to it)
  std::string title;
  int dimension = 0;
  int threads = 0;

  // [geometry]
  double spacing = 0.0;
  std::vector<double> box_lower, box_upper;  ///< the box, when there is exactly one
  /// Every box (lower, upper) when there are several: their union on one lattice.
  std::vector<std::pair<std::vector<double>, std::vector<double>>> boxes;
  std::string particle_file;                 ///< resolved against `directory`

  // [material]
  double young_modulus = 0.0, poisson_ratio = 0.0, density = 0.0;
  PlaneMode plane_mode = PlaneMode::plane_stress;
  /// material.model and its parameters (issue 16; docs/cases.md, [material]): the keys of
  /// the chosen model only. fluidity 0: rate independent (no Perzyna regularisation).
  struct Plasticity {
    std::string model = "elastic";  ///< elastic, j2, johnson_cook, drucker_prager
    double yield_stress = 0.0, isotropic_hardening = 0.0, kinematic_hardening = 0.0;      // j2
    double a = 0.0, b = 0.0, n = 1.0, c = 0.0, reference_rate = 1.0;                      // johnson_cook
    bool thermal = false;
    double room_temperature = 293.0, melt_temperature = 0.0, m = 1.0, specific_heat = 0.0, taylor_quinney = 0.9;
    double cohesion = 0.0, friction_angle = 0.0, dilation_angle = 0.0, hardening = 0.0;  // drucker_prager
    double tension_cutoff = std::numeric_limits<double>::infinity();
    std::string cone = "plane_strain";
    double fluidity = 0.0, exponent = 1.0;  // j2, drucker_prager: Perzyna
  };
  Plasticity plasticity;

  // [method]
  KernelKind kernel = KernelKind::cubic_spline;
  double alpha = 0.0;
  InterpolationKind interpolation = InterpolationKind::linear;
  Kinematics kinematics = Kinematics::small_strain;
  /// The four below: absent from the case, the automatic default of
  /// resolve_automatic_options (solver/settings.hpp; kAutomaticOption, automatic).
  double hourglass = kAutomaticOption;             ///< SolverSettings::hourglass_coefficient
  double hourglass_stiffness = kAutomaticOption;  ///< SolverSettings::hourglass_stiffness
  std::string hourglass_kick = "predicted";  ///< SolverSettings::hourglass_kick: predicted, midpoint
  std::string hourglass_reference = "flow";  ///< SolverSettings::hourglass_reference: flow, initial
  /// method.velocity_wall: SolverSettings::velocity_wall (the same names and order).
  enum class VelocityWall { automatic, characteristics, wall_gradient };
  VelocityWall velocity_wall = VelocityWall::automatic;
  Toggle surface_extrapolation = Toggle::automatic;  ///< SolverSettings::surface_extrapolation
  Toggle volumetric_average = Toggle::automatic;     ///< SolverSettings::volumetric_average
  bool material_velocity_motion = true;  ///< SolverSettings::material_velocity_motion
  std::string surface_motion = "linear";  ///< SolverSettings::surface_motion: linear, shepard
  bool conservative_momentum = false;    ///< SolverSettings::conservative_momentum
  std::string deficient_stencils = "keep";  ///< SolverSettings::deficient_stencils: keep, widen, widen_motion, complete
  std::string kernel_configuration = "reference";  ///< SolverSettings::kernel_configuration: current, reference
  Toggle free_edge_uniaxial = Toggle::automatic;  ///< SolverSettings::free_edge_uniaxial (3D only)
  std::vector<double> body_force;

  // [solver]
  NeighborSearch neighbor_search = NeighborSearch::automatic;
  bool transpose_lists = false;
  double neighbor_skin = 0.05;  ///< SolverSettings::neighbor_skin
  double kernel_cache_mb = 256.0;  ///< SolverSettings::kernel_cache_bytes, in MiB

  // [time]
  double end_time = 0.0;
  double cfl = 0.0;  ///< dt = cfl dx / c_p, or
  double dt = 0.0;   ///< a fixed step (exactly one of the two is non-zero)
  /// time.adaptive: the step shrinks with the smallest current spacing,
  /// dt = min(cfl dx / c_p, cfl dx lambda_min(F) / c_p(rho)) (engine/solver/time_step.hpp).
  bool adaptive_time_step = false;
  bool force = false;  ///< accept a cfl above 1 (or dt above dx / c_p): it diverges (studies)

  std::vector<BoundarySpec> boundaries;

  // [initial]
  std::vector<double> initial_velocity, velocity_gradient, initial_stress;
  /// [initial.profile] type = "sine" (or an array [[initial.profile]]: their sum):
  /// v += amplitude sin(2 pi (x0 . direction / |direction|) / wavelength + phase).
  std::vector<VelocityWave> velocity_waves;
  /// [initial.profile] type = "cantilever_mode" | "twist" (summed with the waves).
  std::vector<VelocityShape> velocity_shapes;

  // [damping]
  double damping = 0.0;
  double rest_velocity = 0.0;  ///< 0: no speed criterion
  double rest_kinetic_energy = 0.0;  ///< J (per unit thickness in 2D); 0: no energy criterion
  double rest_after = 0.0;
  std::string rest_probe;      ///< empty: the fastest real particle

  // [output]
  std::vector<double> output_times;
  std::int64_t output_every = 0;
  std::vector<std::string> fields;
  bool output_virtual = false;
  std::vector<ProbeSpec> probes;
  std::int64_t probe_every = 1;
  /// Steps between the rows of energy.csv (also written at every frame); 0: no ledger.
  std::int64_t energy_every = 10;
  std::int64_t checkpoint_every = 0;  ///< steps; 0: only on interruption

  // [exact]
  std::string exact;  ///< "" | bar | cantilever
  double bar_amplitude = 0.0, bar_pulse_duration = 0.0;
  std::string bar_left_end = "fixed";

  bool has_field(const std::string& name) const;
};

/// The output fields a case may list.
const std::vector<std::string>& known_output_fields();

/// Reads and validates a case. `overrides` are "a.b=value" strings (--set), applied to
/// the TOML table before validation; a value is TOML (1e-3, true, "text", [1, 2]) or,
/// failing that, a bare string. Throws CaseError.
CaseFile load_case(const std::string& path, const std::vector<std::string>& overrides = {});

/// Material::pressure_independent_yield of a case's material, before it is built: j2,
/// johnson_cook, drucker_prager with friction_angle = 0 and no tension_cutoff; in 2D in
/// plane strain.
bool pressure_independent_yield(const CaseFile& c);

/// The same from TOML text (a case written in code: the benchmark block, the tests);
/// `name` stands for the file name in messages and the case's path.
CaseFile load_case_text(const std::string& text, const std::string& name,
                        const std::vector<std::string>& overrides = {});

/// The edit distance used to suggest the nearest valid key.
std::size_t edit_distance(const std::string& a, const std::string& b);

}  // namespace tsph
