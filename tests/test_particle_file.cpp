// Particle files: reading real particles from CSV, generating their virtual
// particles, and refusing bad files with the file, line, column and value.
#include "engine/lattice.hpp"
#include "engine/particle_file.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace tsph {
namespace {

class ParticleFile : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& text) {
    const auto path = std::filesystem::temp_directory_path() /
                      ("tsph_test_" + std::to_string(::getpid()) + "_" + name);
    std::ofstream(path) << text;
    paths_.push_back(path);
    return path.string();
  }
  void TearDown() override {
    for (const auto& p : paths_) std::filesystem::remove(p);
  }
  std::string message_of(const std::string& path) {
    try {
      read_particle_csv<2>(path, 0.1, 1000.0);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "(no error)";
  }

 private:
  std::vector<std::filesystem::path> paths_;
};

// An L-shaped lattice (a 4 x 4 square of nodes without its 2 x 2 top-right block of
// nodes) has 5 of its 9 cells filled; every field of the file is read.
TEST_F(ParticleFile, ReadsAnLShapeAndFillsItsCellsWithVirtualParticles) {
  std::string text = "# an L-shaped lattice\nx,y,vx,sxy,group\n";
  int count = 0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      if (i >= 2 && j >= 2) continue;  // cut out the corner
      text += std::to_string(0.1 * i) + "," + std::to_string(0.1 * j) + ",1.5,-2," +
              std::to_string(i == 0 ? 7 : 0) + "\n";
      ++count;
    }
  const auto path = write("l.csv", text);
  const ParticleSet<2> real = read_particle_csv<2>(path, 0.1, 1000.0);
  ASSERT_EQ(real.size(), static_cast<std::size_t>(count));
  EXPECT_EQ(real.velocity[0][3], 1.5);
  EXPECT_EQ(real.stress[2][3], -2.0);
  EXPECT_EQ(real.group[0], 7);
  EXPECT_EQ(real.group[1], 0);
  EXPECT_NEAR(real.volume[5], 0.01, 1e-15);
  EXPECT_NEAR(real.mass[5], 10.0, 1e-12);
  // Of the 3 x 3 cells, those with a corner among the removed nodes (i, j >= 2) are
  // cells (1,1), (2,1), (1,2) and (2,2): 9 - 4 = 5 virtual particles.
  const ParticleSet<2> virtual_particles = make_virtual_particles(real, 0.1, 1000.0);
  EXPECT_EQ(virtual_particles.size(), 5u);
  // On a box the generator reproduces make_virtual_lattice.
  LatticeBox<2> box;
  box.spacing = 0.1;
  box.node_count = {5, 3};
  const auto lattice = make_real_lattice(box, 1000.0);
  EXPECT_EQ(make_virtual_particles(lattice, 0.1, 1000.0).size(),
            make_virtual_lattice(box, 1000.0).size());
}

TEST_F(ParticleFile, BadFilesAreRefusedWithTheirLineColumnAndValue) {
  EXPECT_NE(message_of("/nonexistent/particles.csv").find("cannot be opened"), std::string::npos);
  EXPECT_NE(message_of(write("empty.csv", "")).find("is empty"), std::string::npos);
  EXPECT_NE(message_of(write("col.csv", "x,y,temperature\n0,0,1\n"))
                .find("line 1: unknown column 'temperature'; valid columns:"),
            std::string::npos);
  EXPECT_NE(message_of(write("noy.csv", "x,vx\n0,0\n")).find("lacks the column 'y'"),
            std::string::npos);
  EXPECT_NE(message_of(write("nan.csv", "x,y\n0,0\n0.1,nan\n"))
                .find("line 3: column 'y' = 'nan' is not a finite number"),
            std::string::npos);
  EXPECT_NE(message_of(write("text.csv", "x,y\n0,zero\n")).find("column 'y' = 'zero'"),
            std::string::npos);
  EXPECT_NE(message_of(write("fields.csv", "x,y\n0,0,3\n")).find("line 2: 3 fields, the header has 2"),
            std::string::npos);
  EXPECT_NE(message_of(write("dup.csv", "x,y\n0,0\n0.1,0\n0,0\n"))
                .find("lines 2 and 4 are closer than dx / 2"),
            std::string::npos);
  EXPECT_NE(message_of(write("overlap.csv", "x,y\n0,0\n0.02,0.01\n")).find("overlapping"),
            std::string::npos);
  EXPECT_NE(message_of(write("volume.csv", "x,y,volume\n0,0,-1\n")).find("volume = -1 must be positive"),
            std::string::npos);
  EXPECT_NE(message_of(write("none.csv", "x,y\n")).find("holds no particle"), std::string::npos);
  EXPECT_NE(message_of(write("twice.csv", "x,y,x\n0,0,0\n")).find("column 'x' appears twice"),
            std::string::npos);
  EXPECT_NE(message_of(write("group.csv", "x,y,group\n0,0,1.5\n"))
                .find("group = 1.5 must be a 32-bit integer"),
            std::string::npos);
  EXPECT_NE(message_of(write("huge.csv", "x,y,group\n0,0,3e9\n")).find("must be a 32-bit integer"),
            std::string::npos);
  // Windows line endings are accepted.
  EXPECT_EQ(message_of(write("crlf.csv", "x,y\r\n0,0\r\n0.1,0\r\n")), "(no error)");
}

}  // namespace
}  // namespace tsph
