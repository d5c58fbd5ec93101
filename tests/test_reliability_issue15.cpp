// Issue 15 (docs/reliability.md): checkpoint integrity (crc32 and size checks, every
// bit flip and truncation refused), the physics record of a restart, checkpoint pruning,
// the run lock, the thread-count rule, the address-space limit, and the particle-file
// checks (special files, a missing header, duplicates in O(N log N) against brute force).
// The command-line side of the same items: tsph_reliability_checks.sh.
#include "engine/case/case_file.hpp"
#include "engine/case/restart_check.hpp"
#include "engine/memory_estimate.hpp"
#include "engine/output/checkpoint.hpp"
#include "engine/particle_file.hpp"
#include "engine/run_lock.hpp"
#include "engine/threads.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <type_traits>

#include <fmt/core.h>
#include <fmt/format.h>

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

namespace tsph {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("tsph_issue15_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<char> read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

output::Checkpoint<2> small_checkpoint() {
  output::Checkpoint<2> c;
  c.real.resize(7);
  c.virtual_particles.resize(3);
  for (std::size_t i = 0; i < 7; ++i) {
    c.real.position[0][i] = 0.1 * static_cast<double>(i);
    c.real.velocity[1][i] = -0.5 * static_cast<double>(i);
    c.real.stress[2][i] = 1e3 * static_cast<double>(i);
  }
  c.time = 1.25e-3;
  c.steps = 42;
  c.frames = 2;
  c.real_series = {{0.0, "particles_000000.vtu"}, {1e-3, "particles_000001.vtu"}};
  c.errors = {{1e-3, "velocity_x_l2_percent", 2.5}};
  c.physics = "dimension = 2\nmaterial.E = 80000000\n";
  c.energy.boundary = {12.5, -0.25};
  c.energy.hourglass = -3.0;
  c.energy.initial_energy = 7.0;
  return c;
}

/// The bytes of `c`'s checkpoint (format 5) as the format `format` (3 or 4) held them: without
/// the hourglass reference of both sets (ParticleSet::hourglass_reference: a count and the
/// values per component), format 3 also without the ledger; magic, size and checksum set.
std::vector<char> as_older_format(const std::vector<char>& written, const output::Checkpoint<2>& c, char format) {
  std::vector<char> bytes;
  std::size_t at = output::detail::kCheckpointPrefixBytes + 4 + 8 + c.physics.size() + 4 + 8 + 8 + 8;
  std::size_t copied = 0;
  for (const ParticleSet<2>* set : {&c.real, &c.virtual_particles}) {
    at += 8;
    ParticleSet<2> copy = *set;
    copy.for_each_field([&](auto& field) {
      const std::size_t size = 8 + field.size() * sizeof(field[0]);
      if constexpr (std::is_same_v<std::decay_t<decltype(field)>, std::vector<double>>)
        if (copy.is_hourglass_reference(field)) {
          bytes.insert(bytes.end(), written.begin() + static_cast<std::ptrdiff_t>(copied),
                       written.begin() + static_cast<std::ptrdiff_t>(at));
          copied = at + size;
        }
      at += size;
    });
  }
  bytes.insert(bytes.end(), written.begin() + static_cast<std::ptrdiff_t>(copied), written.end());
  if (format == '3') bytes.resize(bytes.size() - (7 * 8 + 2 * 8 + 2 * 8));  // the ledger: 7 doubles, two counts, 2 doubles
  bytes[7] = format;
  const std::uint64_t body = bytes.size() - output::detail::kCheckpointPrefixBytes;
  const std::uint32_t crc = output::detail::crc32_of(bytes.data() + output::detail::kCheckpointPrefixBytes, body);
  std::memcpy(bytes.data() + 8, &body, sizeof body);
  std::memcpy(bytes.data() + 16, &crc, sizeof crc);
  return bytes;
}

std::string refusal(const std::vector<char>& bytes) {
  try {
    (void)output::parse_checkpoint<2>(bytes, "k.bin");
  } catch (const output::CheckpointError& e) {
    return e.what();
  }
  return "";
}

TEST(CheckpointIntegrity, RoundTripKeepsStateAndPhysics) {
  const fs::path dir = scratch("roundtrip");
  const auto written = small_checkpoint();
  output::write_checkpoint((dir / "k.bin").string(), written);
  const auto read = output::read_checkpoint<2>((dir / "k.bin").string());
  EXPECT_EQ(read.physics, written.physics);
  EXPECT_EQ(read.steps, 42);
  EXPECT_EQ(read.time, 1.25e-3);
  EXPECT_EQ(read.real.stress[2], written.real.stress[2]);
  EXPECT_EQ(read.real_series.back().file, "particles_000001.vtu");
  const auto header = output::read_checkpoint_header((dir / "k.bin").string());
  EXPECT_EQ(header.dimension, 2);
  EXPECT_EQ(header.steps, 42);
  EXPECT_EQ(header.physics, written.physics);
  EXPECT_THROW((void)output::read_checkpoint<3>((dir / "k.bin").string()), output::CheckpointError);
  fs::remove_all(dir);
}

// Format 4 holds the energy ledger; a format 3 file (the same without it) is read with
// an empty ledger.
TEST(CheckpointIntegrity, EnergyLedgerRoundTripAndFormatThree) {
  const fs::path dir = scratch("ledger");
  const auto written = small_checkpoint();
  output::write_checkpoint((dir / "k.bin").string(), written);
  const auto read = output::read_checkpoint<2>((dir / "k.bin").string());
  EXPECT_EQ(read.energy.boundary, written.energy.boundary);
  EXPECT_EQ(read.energy.hourglass, -3.0);
  EXPECT_EQ(read.energy.initial_energy, 7.0);
  // Format 3: magic "TSPHCKP3", the ledger's bytes and the hourglass reference gone.
  const auto old = output::parse_checkpoint<2>(as_older_format(read_all(dir / "k.bin"), written, '3'), "k3.bin");
  EXPECT_EQ(old.steps, 42);
  EXPECT_EQ(old.real.stress[2], written.real.stress[2]);
  EXPECT_TRUE(old.energy.boundary.empty());
  EXPECT_TRUE(std::isnan(old.energy.initial_energy));
  fs::remove_all(dir);
}

// Format 5 holds the hourglass reference among the plastic fields; a format 4 file (the
// same without it) is read with the reference zero, the other plastic fields as written.
TEST(CheckpointIntegrity, HourglassReferenceRoundTripAndFormatFour) {
  const fs::path dir = scratch("reference");
  auto written = small_checkpoint();
  written.real.carry_plastic_fields(293.0);
  for (std::size_t i = 0; i < written.real.size(); ++i) {
    written.real.plastic_strain[i] = 0.01 * static_cast<double>(i);
    written.real.hourglass_reference[0][i] = 1e-6 * static_cast<double>(i + 1);
    written.real.hourglass_reference[1][i] = -2e-6 * static_cast<double>(i + 1);
  }
  output::write_checkpoint((dir / "k.bin").string(), written);
  const auto read = output::read_checkpoint<2>((dir / "k.bin").string());
  EXPECT_EQ(read.real.hourglass_reference, written.real.hourglass_reference);
  EXPECT_EQ(read.real.plastic_strain, written.real.plastic_strain);
  EXPECT_TRUE(read.virtual_particles.hourglass_reference[0].empty());
  const auto old = output::parse_checkpoint<2>(as_older_format(read_all(dir / "k.bin"), written, '4'), "k4.bin");
  EXPECT_EQ(old.real.plastic_strain, written.real.plastic_strain);
  EXPECT_EQ(old.real.temperature, written.real.temperature);
  for (int d = 0; d < 2; ++d) EXPECT_EQ(old.real.hourglass_reference[d], std::vector<double>(7, 0.0));
  EXPECT_TRUE(old.virtual_particles.hourglass_reference[0].empty());
  EXPECT_EQ(old.energy.boundary, written.energy.boundary);
  fs::remove_all(dir);
}

TEST(CheckpointIntegrity, EveryBitFlipIsRefused) {
  const fs::path dir = scratch("flip");
  output::write_checkpoint((dir / "k.bin").string(), small_checkpoint());
  const std::vector<char> good = read_all(dir / "k.bin");
  ASSERT_EQ(refusal(good), "");
  // crc32 detects every single-bit error; the size and magic are checked before it.
  for (std::size_t byte = 0; byte < good.size(); ++byte)
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<char> bad = good;
      bad[byte] = static_cast<char>(bad[byte] ^ (1 << bit));
      const std::string why = refusal(bad);
      ASSERT_FALSE(why.empty()) << "a flip of bit " << bit << " of byte " << byte << " was accepted";
      if (byte >= 20) {
        EXPECT_NE(why.find("checksum check failed"), std::string::npos) << why;
      }
    }
  fs::remove_all(dir);
}

TEST(CheckpointIntegrity, TruncatedAndOverwrittenAreRefusedNamingTheCheck) {
  const fs::path dir = scratch("trunc");
  output::write_checkpoint((dir / "k.bin").string(), small_checkpoint());
  const std::vector<char> good = read_all(dir / "k.bin");
  for (std::size_t size = 0; size < good.size(); ++size) {
    const std::string why = refusal(std::vector<char>(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(size)));
    ASSERT_FALSE(why.empty()) << "truncated to " << size << " bytes was accepted";
    if (size >= 20) {
      EXPECT_NE(why.find("size check failed"), std::string::npos) << why;
    }
  }
  std::vector<char> over = good;
  for (std::size_t k = 100; k < 160 && k < over.size(); ++k) over[k] = static_cast<char>(0x5a);
  EXPECT_NE(refusal(over).find("'k.bin' is damaged: checksum check failed"), std::string::npos);
  std::vector<char> longer = good;
  longer.push_back('x');
  EXPECT_NE(refusal(longer).find("size check failed"), std::string::npos);
  fs::remove_all(dir);
}

TEST(CheckpointIntegrity, FormatOneIsRefusedWithAReason) {
  std::vector<char> old = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '1', 2, 0, 0, 0};
  EXPECT_NE(refusal(old).find("format 1"), std::string::npos);
  EXPECT_NE(refusal({'n', 'o', 't', ' ', 'o', 'n', 'e', '!', 0}).find("is not a tsph checkpoint"), std::string::npos);
}

CaseFile bar_case(const std::vector<std::string>& overrides = {}) {
  return load_case(std::string(TSPH_SOURCE_DIR) + "/tools/cases/bar.toml", overrides);
}

TEST(PhysicsRecord, NamesTheKeysThatDifferAndIgnoresRunControl) {
  const std::string base = physics_record(bar_case());
  EXPECT_EQ(physics_record(bar_case()), base);  // canonical: the same case, the same record
  // Output and run-control keys are not physics.
  EXPECT_EQ(physics_record(bar_case({"time.end=1e-2", "threads=1", "output.probe_every=5", "title=\"x\""})), base);
  const auto differ = physics_differences(base, physics_record(bar_case({"material.E=9e7", "method.alpha=0.9"})));
  ASSERT_EQ(differ.size(), 2u);
  EXPECT_EQ(differ[0], "material.E = 90000000 (the checkpoint: 80000000)");
  EXPECT_EQ(differ[1], "method.alpha = 0.9 (the checkpoint: 0.6)");
  // Damping and the time step are physics too.
  EXPECT_EQ(physics_differences(base, physics_record(bar_case({"damping.coefficient=10"}))).front(),
            "damping.coefficient = 10 (the checkpoint: 0)");
  EXPECT_EQ(physics_differences(base, physics_record(bar_case({"time.cfl=0.5"}))).front(),
            "time.cfl = 0.5 (the checkpoint: 1)");
}

TEST(PhysicsRecord, RestartFallsBackToTheNewestIntactCheckpoint) {
  const fs::path dir = scratch("fallback");
  const CaseFile c = bar_case();
  output::Checkpoint<1> k;
  k.real.resize(2);
  k.physics = physics_record(c);
  for (int step : {10, 20, 30}) {
    k.steps = step;
    output::write_checkpoint((dir / fmt::format("checkpoint_{:010d}.bin", step)).string(), k);
  }
  fs::resize_file(dir / "checkpoint_0000000030.bin", 40);  // the newest truncated
  std::FILE* log = std::tmpfile();
  EXPECT_EQ(select_restart_checkpoint(c, dir.string(), log), (dir / "checkpoint_0000000020.bin").string());
  std::rewind(log);
  char text[1024] = {};
  (void)!std::fread(text, 1, sizeof text - 1, log);
  std::fclose(log);
  EXPECT_NE(std::string(text).find("checkpoint_0000000030.bin' is damaged: size check failed"), std::string::npos);
  EXPECT_NE(std::string(text).find("falling back to"), std::string::npos);
  // Another physics: refused (CaseError, exit status 2) naming the key.
  try {
    (void)select_restart_checkpoint(bar_case({"material.rho=1000"}), dir.string(), nullptr);
    ADD_FAILURE() << "a restart with another density was accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("material.rho = 1000 (the checkpoint: 2000)"), std::string::npos) << e.what();
  }
  // A damaged file named explicitly: refused, no fallback.
  EXPECT_THROW((void)select_restart_checkpoint(c, (dir / "checkpoint_0000000030.bin").string(), nullptr), CaseError);
  fs::remove_all(dir);
}

TEST(PhysicsRecord, PruningKeepsTheNewestTwoUpToTheOneWritten) {
  const fs::path dir = scratch("prune");
  for (int step : {10, 20, 30, 40, 50}) std::ofstream(dir / fmt::format("checkpoint_{:010d}.bin", step)) << "x";
  prune_checkpoints(dir.string(), (dir / "checkpoint_0000000040.bin").string());
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"checkpoint_0000000030.bin", "checkpoint_0000000040.bin",
                                            "checkpoint_0000000050.bin"}));
  fs::remove_all(dir);
}

TEST(RunLock, SecondHolderIsRefusedUntilTheFirstEnds) {
  const fs::path dir = scratch("lock") / "out";
  RunLock first, second;
  EXPECT_FALSE(first.acquire(dir.string()).has_value());
  EXPECT_TRUE(first.held());
  const auto refused = second.acquire(dir.string());
  ASSERT_TRUE(refused.has_value());
  EXPECT_NE(refused->find("is in use by another tsph run (pid " + std::to_string(::getpid()) + ")"), std::string::npos)
      << *refused;
  EXPECT_TRUE(output_directory_empty(dir.string()));  // the lock file does not count
  first = RunLock();                                   // released
  EXPECT_FALSE(second.acquire(dir.string()).has_value());
  fs::remove_all(dir.parent_path());
}

TEST(Threads, OneRuleForFlagAndKey) {
  const auto limit = max_thread_count();
  EXPECT_GE(limit, 64);
  EXPECT_LE(limit, kMaxThreads);
  EXPECT_FALSE(thread_count_error("--threads", 0));
  EXPECT_FALSE(thread_count_error("--threads", limit));
  const auto error = thread_count_error("--threads", 100000);
  ASSERT_TRUE(error);
  EXPECT_NE(error->find("--threads = 100000 is invalid: must lie in [0, " + std::to_string(limit) + "]"),
            std::string::npos);
  EXPECT_TRUE(thread_count_error("threads", limit + 1));
  EXPECT_TRUE(thread_count_error("threads", -1));
  try {
    (void)bar_case({"threads=100000"});
    ADD_FAILURE() << "threads = 100000 accepted";
  } catch (const CaseError& e) {
    EXPECT_NE(std::string(e.what()).find("threads = 100000 is invalid: must lie in [0, " + std::to_string(limit)),
              std::string::npos)
        << e.what();
  }
}

TEST(MemoryLimit, AddressSpaceLimitIsALimit) {
  struct rlimit saved {};
  ASSERT_EQ(::getrlimit(RLIMIT_AS, &saved), 0);
  struct rlimit lowered = saved;
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0;
  statm >> pages;
  const std::size_t mapped = pages * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  lowered.rlim_cur = mapped + (std::size_t{256} << 20);  // 256 MiB beyond what is mapped
  if (saved.rlim_max != RLIM_INFINITY && lowered.rlim_cur > saved.rlim_max) GTEST_SKIP() << "hard limit too low";
  ASSERT_EQ(::setrlimit(RLIMIT_AS, &lowered), 0);
  std::string source;
  const std::size_t limit = memory_limit_bytes(&source);
  ASSERT_EQ(::setrlimit(RLIMIT_AS, &saved), 0);
  EXPECT_GT(limit, 0u);
  EXPECT_LE(limit, std::size_t{256} << 20);
  EXPECT_NE(source.find("RLIMIT_AS"), std::string::npos) << source;
}

TEST(ParticleFileChecks, SpecialFilesAreRefusedWithoutReading) {
  const fs::path dir = scratch("special");
  for (const char* device : {"/dev/urandom", "/dev/zero"}) {
    const auto problem = particle_file_problem(device);
    ASSERT_TRUE(problem) << device;
    EXPECT_NE(problem->find("not a regular file (a device)"), std::string::npos) << *problem;
    EXPECT_THROW((void)read_particle_csv<2>(device, 0.1, 1000.0), std::invalid_argument);
  }
  EXPECT_NE(particle_file_problem(dir.string())->find("is a directory"), std::string::npos);
  const fs::path fifo = dir / "fifo.csv";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(particle_file_problem(fifo.string())->find("a FIFO"), std::string::npos);
  std::ofstream(dir / "empty.csv").close();
  EXPECT_NE(particle_file_problem((dir / "empty.csv").string())->find("is empty"), std::string::npos);
  EXPECT_NE(particle_file_problem((dir / "none.csv").string())->find("No such file"), std::string::npos);
  fs::remove_all(dir);
}

TEST(ParticleFileChecks, MissingHeaderIsNamed) {
  std::istringstream in("0.0,0.0\n0.1,0.0\n");
  try {
    (void)read_particle_csv<2>(in, "p.csv", 0.1, 1000.0);
    ADD_FAILURE() << "a header-less file was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 1: the header line is missing"), std::string::npos) << e.what();
  }
}

/// The duplicate check against brute force: the first i (file order) with a partner
/// within dx / 2, and its first partner.
std::optional<std::pair<std::size_t, std::size_t>> brute_force_pair(const std::vector<std::array<double, 2>>& p,
                                                                    double radius) {
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i == j) continue;
      const double dx = p[i][0] - p[j][0], dy = p[i][1] - p[j][1];
      if (dx * dx + dy * dy <= radius * radius) return std::make_pair(std::min(i, j), std::max(i, j));
    }
  return std::nullopt;
}

TEST(ParticleFileChecks, DuplicateCheckAgreesWithBruteForce) {
  std::mt19937 random(15);
  int refused = 0, accepted = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::uniform_real_distribution<double> coordinate(0.0, 0.3 + trial * 0.01);
    std::vector<std::array<double, 2>> points(2 + static_cast<std::size_t>(trial % 40));
    std::string text = "x,y\n";
    for (auto& p : points) {
      p = {coordinate(random), coordinate(random)};
      text += fmt::format("{:.17g},{:.17g}\n", p[0], p[1]);
    }
    const auto expected = brute_force_pair(points, 0.05);
    std::istringstream in(text);
    try {
      (void)read_particle_csv<2>(in, "p.csv", 0.1, 1000.0);
      EXPECT_FALSE(expected) << "trial " << trial << ": a close pair was missed";
      ++accepted;
    } catch (const std::invalid_argument& e) {
      ASSERT_TRUE(expected) << "trial " << trial << ": " << e.what();
      ++refused;
      const std::string lines = "lines " + std::to_string(expected->first + 2) + " and " +
                                std::to_string(expected->second + 2) + " are closer";
      EXPECT_NE(std::string(e.what()).find(lines), std::string::npos) << e.what() << " (expected " << lines << ")";
    }
  }
  EXPECT_GT(refused, 30);  // both outcomes are exercised
  EXPECT_GT(accepted, 30);
  std::printf("duplicate check: %d sets refused, %d accepted, as brute force\n", refused, accepted);
}

TEST(ParticleFileChecks, MillionParticlesAnsweredInSeconds) {
  std::string identical = "x,y\n", lattice = "x,y\n";
  for (int i = 0; i < 1000000; ++i) identical += "0.5,0.5\n";
  for (int i = 0; i < 1000; ++i)
    for (int j = 0; j < 1000; ++j) lattice += fmt::format("{},{}\n", 0.1 * i, 0.1 * j);
  const auto start = std::chrono::steady_clock::now();
  std::istringstream same(identical);
  try {
    (void)read_particle_csv<2>(same, "p.csv", 0.1, 1000.0);
    ADD_FAILURE() << "1e6 identical points accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("lines 2 and 3 are closer than dx / 2"), std::string::npos) << e.what();
  }
  std::istringstream distinct(lattice);
  EXPECT_EQ(read_particle_csv<2>(distinct, "p.csv", 0.1, 1000.0).size(), 1000000u);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // On main (all neighbour pairs first) 3e4 identical points took 11.6 s and 3.5 GB.
  EXPECT_LT(seconds, 60.0);
}

}  // namespace
}  // namespace tsph
