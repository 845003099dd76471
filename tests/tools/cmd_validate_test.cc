// hapvox validate hertz and the contact-law flags, through the command line.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "test_data.h"

namespace hapvox::testing {
namespace {

TEST(ValidateCli, HertzWritesTheComparisonAndPasses) {
  const std::string dir = scratch_dir() + "/hertz";
  const CommandResult r = run_hapvox("validate hertz -o " + dir +
                                     " --radii-mm 4 --poisson 0.3,0.49 --voxels-mm 0.5 "
                                     "--no-plot");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ok"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("FAIL"), std::string::npos) << r.out;
  std::ifstream csv(dir + "/hertz.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header,
            "radius_mm,poisson,voxel_mm,depth_mm,force_hertz_law_n,force_paper_law_n,"
            "force_hertz_n");
  // Every row: the default law within 5 % of Hertz once a voxel deep (d >= 0.5 mm); the
  // paper's law off by far more at nu = 0.49.
  int rows = 0, paper_far_off = 0;
  for (std::string line; std::getline(csv, line);) {
    std::istringstream fields(line);
    double r_mm, nu, h, d, ours, paper, hertz;
    char comma;
    fields >> r_mm >> comma >> nu >> comma >> h >> comma >> d >> comma >> ours >> comma >> paper >>
        comma >> hertz;
    ASSERT_TRUE(fields) << line;
    if (d < h) continue;
    ++rows;
    EXPECT_NEAR(ours, hertz, 0.05 * hertz) << line;
    if (nu > 0.48 && paper > 3.0 * hertz) ++paper_far_off;
  }
  EXPECT_GT(rows, 100);
  EXPECT_GT(paper_far_off, 10);
  EXPECT_FALSE(std::filesystem::exists(dir + "/hertz.csv.partial"));
}

TEST(ValidateCli, BadListsAreOneLineErrors) {
  CommandResult r = run_hapvox("validate hertz -o " + scratch_dir() + " --radii-mm 4,x --no-plot");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: --radii-mm: expected a comma-separated list of numbers, got '4,x'\n");
  r = run_hapvox("validate hertz -o " + scratch_dir() + " --poisson 0.5 --no-plot");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hapvox: error: --poisson: ratios must lie in (-1, 0.5)\n");
}

TEST(ContactLawCli, ReferenceLengthNeedsThePaperLaw) {
  const std::string dir = scratch_dir();
  const std::string trace = dir + "/p.csv";
  ASSERT_EQ(
      run_hapvox("trace make press -o " + trace + " --start-mm 32,32,40 --travel-mm 10").exit_code,
      0);
  CommandResult r = run_hapvox("replay " + trace + " --volume block:dims=64 -o " + dir +
                               "/a.h5 --reference-length-mm 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hapvox: error: --reference-length-mm: needs --contact-law paper (the Hertz law "
            "measures L from the contact)\n");
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.h5"));
  r = run_hapvox("replay " + trace + " --volume block:dims=64 -o " + dir +
                 "/b.h5 --contact-law paper --reference-length-mm 4");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = run_hapvox("replay " + trace + " --volume block:dims=64 -o " + dir +
                 "/c.h5 --surface-density 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "hapvox: error: --surface-density: must lie in (0, 1], not 0\n");
  r = run_hapvox("replay " + trace + " --volume block:dims=64 -o " + dir +
                 "/d.h5 --contact-law hooke");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--contact-law"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hapvox::testing
