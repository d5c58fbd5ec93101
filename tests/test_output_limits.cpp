// Resource limits and output failures of the tsph command's engine (issue 6): the
// up-front estimate of memory and output size counts what the run will hold and write
// (checked against a real run's files), a case that exceeds the limits is refused with
// the estimate and the limit, and the VTU, PVD and checkpoint writers report a failed
// write (a full disk: /dev/full) naming the file, leaving the previous file intact.
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/lattice.hpp"
#include "engine/memory_estimate.hpp"
#include "engine/output/checkpoint.hpp"
#include "engine/output/vtu_writer.hpp"
#include "engine/output_file.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

namespace tsph {
namespace {

namespace fs = std::filesystem;

const fs::path kCases = fs::path(TSPH_SOURCE_DIR) / "tools" / "cases";

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class OutputLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("tsph_output_limits_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir_;
};

// The bar case (101 real, 100 virtual particles, 150 steps, the initial frame, two
// output times and the final one): the estimate counts them, and its frame and total
// output sizes lie within 10 % above what a real run writes.
TEST_F(OutputLimitsTest, EstimateCountsTheBarCaseAndBoundsItsOutput) {
  const CaseFile c = load_case((kCases / "bar.toml").string(), {"output.checkpoint_every=50"});
  const ResourceEstimate e = estimate_resources(c);
  EXPECT_EQ(e.real_particles, 101.0);
  EXPECT_EQ(e.virtual_particles, 100.0);
  EXPECT_EQ(e.steps, 150.0);
  EXPECT_EQ(e.frames, 4.0);
  RunOptions o;
  o.out_dir = dir_.string();
  o.quiet = true;
  const RunReport r = run_case(c, o);
  EXPECT_EQ(static_cast<double>(r.steps), e.steps);
  EXPECT_LE(static_cast<double>(r.frames), e.frames);
  const double frame = static_cast<double>(fs::file_size(dir_ / "particles_000001.vtu"));
  EXPECT_GE(e.frame_bytes, frame);
  EXPECT_LE(e.frame_bytes, frame + 2048.0 + 0.1 * frame);  // the XML allowance and 10 %
  const double checkpoint = static_cast<double>(fs::file_size(r.last_checkpoint));
  EXPECT_GE(e.checkpoint_bytes, checkpoint);
  EXPECT_LE(e.checkpoint_bytes, 1.1 * checkpoint + 4096.0);
  double written = 0.0;
  for (const auto& entry : fs::directory_iterator(dir_)) written += static_cast<double>(entry.file_size());
  EXPECT_GE(e.output_bytes, written);
  // Memory: at least the two particle sets the solver holds.
  EXPECT_GE(e.memory_bytes, 201.0 * (8.0 * (4 + 1 + 3) + 12.0));
}

// A plastic run (the footing: Drucker-Prager, plane strain, the volumetric average on):
// its checkpoint holds the real set's internal variables, and the estimate bounds it
// within 10 %; the memory estimate counts those variables and the average's stencils.
TEST_F(OutputLimitsTest, EstimateCountsThePlasticFieldsOfTheFooting) {
  const std::vector<std::string> short_run{"time.end=0.01", "output.times=[0.01]", "output.checkpoint_every=5"};
  const CaseFile c = load_case((kCases / "footing_2d.toml").string(), short_run);
  const ResourceEstimate e = estimate_resources(c);
  RunOptions o;
  o.out_dir = dir_.string();
  o.quiet = true;
  const RunReport r = run_case(c, o);
  ASSERT_FALSE(r.last_checkpoint.empty());
  const double checkpoint = static_cast<double>(fs::file_size(r.last_checkpoint));
  EXPECT_GE(e.checkpoint_bytes, checkpoint);
  EXPECT_LE(e.checkpoint_bytes, 1.1 * checkpoint + 4096.0);
  // Without the volumetric average the memory estimate is smaller by its stencils and
  // rates (56 B per particle of the larger set); the plastic fields are in both.
  std::vector<std::string> without = short_run;
  without.push_back("method.volumetric_average=false");
  const CaseFile plain = load_case((kCases / "footing_2d.toml").string(), without);
  const ResourceEstimate e_plain = estimate_resources(plain);
  EXPECT_NEAR(e.memory_bytes - e_plain.memory_bytes, 56.0 * std::max(e.real_particles, e.virtual_particles), 1e-6);
  // What the estimate and `tsph check` count: the plastic fields in both, the average as
  // resolved; an elastic case neither.
  const MemoryModel model = memory_model(c), plain_model = memory_model(plain);
  EXPECT_TRUE(model.plastic_fields);
  EXPECT_TRUE(model.volumetric_average);
  EXPECT_TRUE(plain_model.plastic_fields);
  EXPECT_FALSE(plain_model.volumetric_average);
  const MemoryModel bar = memory_model(load_case((kCases / "bar.toml").string()));
  EXPECT_FALSE(bar.plastic_fields);
  EXPECT_FALSE(bar.volumetric_average);
}

// Refusals: memory or disk below the estimate gives a CaseError naming the estimate,
// the limit and the way out; limits at or above it (or unknown) pass.
TEST_F(OutputLimitsTest, RunsBeyondTheLimitsAreRefusedWithTheEstimateAndTheLimit) {
  const CaseFile c = load_case((kCases / "cantilever_2d.toml").string());
  const ResourceEstimate e = estimate_resources(c);
  ResourceLimits ample;
  ample.memory_bytes = e.memory_bytes;
  ample.memory_source = "test";
  ample.disk_bytes = e.output_bytes;
  EXPECT_NO_THROW(check_resources(c, e, ample, "out"));
  EXPECT_NO_THROW(check_resources(c, e, ResourceLimits{}, "out"));  // unknown: not checked

  ResourceLimits small_memory = ample;
  small_memory.memory_bytes = 0.5 * e.memory_bytes;
  try {
    check_resources(c, e, small_memory, "out");
    FAIL() << "a run needing twice the memory available was not refused";
  } catch (const CaseError& error) {
    ASSERT_EQ(error.messages().size(), 1u);
    const std::string m = error.messages()[0];
    EXPECT_TRUE(contains(m, "of memory")) << m;
    EXPECT_TRUE(contains(m, "are available (test)")) << m;
    EXPECT_TRUE(contains(m, "--ignore-limits")) << m;
  }
  ResourceLimits small_disk = ample;
  small_disk.disk_bytes = 0.5 * e.output_bytes;
  try {
    check_resources(c, e, small_disk, "somewhere");
    FAIL() << "a run writing twice the free disk was not refused";
  } catch (const CaseError& error) {
    ASSERT_EQ(error.messages().size(), 1u);
    const std::string m = error.messages()[0];
    EXPECT_TRUE(contains(m, "of disk")) << m;
    EXPECT_TRUE(contains(m, "free under out = 'somewhere'")) << m;
    EXPECT_TRUE(contains(m, "output.every")) << m;
  }
}

// A case far beyond any machine (10^12 particles) is refused by the real limits, before
// anything is allocated; the machine's limits are known here.
TEST_F(OutputLimitsTest, ATrillionParticlesAreRefusedOnThisMachine) {
  const CaseFile c = load_case((kCases / "bar.toml").string(), {"geometry.spacing=1e-12"});
  const ResourceEstimate e = estimate_resources(c);
  EXPECT_GT(e.real_particles, 0.99e12);
  const ResourceLimits limits = machine_limits(dir_.string());
  EXPECT_GT(limits.memory_bytes, 0.0);
  ASSERT_TRUE(limits.disk_bytes.has_value());
  EXPECT_THROW(check_resources(c, e, limits, dir_.string()), CaseError);
}

// A full disk (/dev/full behind the temporary name) under each writer of the tsph
// command: OutputError naming the file and the reason; the previous file is intact and
// no temporary file is left.
TEST_F(OutputLimitsTest, WritersReportAFullDiskAndKeepThePreviousFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this system";
  LatticeBox<2> box;
  box.spacing = 0.1;
  box.node_count = {4, 3};
  output::VtuFrame frame;
  frame.point_count = 12;
  frame.points.assign(36, 0.5);
  output::Checkpoint<2> checkpoint;
  checkpoint.real = make_real_lattice(box, 1000.0);
  checkpoint.virtual_particles = make_virtual_lattice(box, 1000.0);
  const auto writers = {
      std::make_pair(std::string("particles_000001.vtu"),
                     std::function<void(const std::string&)>([&](const std::string& p) { output::write_vtu(p, frame); })),
      std::make_pair(std::string("particles.pvd"), std::function<void(const std::string&)>([](const std::string& p) {
                       output::write_pvd(p, {{0.0, "particles_000000.vtu"}, {1.0, "particles_000001.vtu"}});
                     })),
      std::make_pair(std::string("checkpoint_0000000010.bin"),
                     std::function<void(const std::string&)>(
                         [&](const std::string& p) { output::write_checkpoint(p, checkpoint); })),
  };
  for (const auto& [name, write] : writers) {
    const fs::path file = dir_ / name;
    write(file.string());  // the previous, good file
    const std::string before = read(file);
    fs::create_symlink("/dev/full", file.string() + ".tmp");
    try {
      write(file.string());
      ADD_FAILURE() << name << ": a write to a full disk was not reported";
    } catch (const OutputError& e) {
      EXPECT_TRUE(contains(e.what(), file.string())) << e.what();
      EXPECT_TRUE(contains(e.what(), "No space left on device")) << e.what();
    }
    EXPECT_EQ(read(file), before) << name;
    EXPECT_FALSE(fs::exists(fs::symlink_status(file.string() + ".tmp"))) << name;
  }
}

}  // namespace
}  // namespace tsph
