// ChiSquareSurvival against published quantiles of the chi-square distribution.
#include <gtest/gtest.h>

#include "health/check.h"

namespace omni::health {
namespace {

TEST(ChiSquareSurvival, MatchesTableQuantiles) {
  struct Row {
    int dof;
    double x, upper_tail;
  };
  // Upper-tail critical values (NIST/SEMATECH e-Handbook, table 1.3.6.7.4).
  const Row rows[] = {{1, 3.841, 0.05},    {1, 6.635, 0.01},   {2, 5.991, 0.05},
                      {10, 18.307, 0.05},  {10, 23.209, 0.01}, {50, 67.505, 0.05},
                      {100, 124.342, 0.05}, {100, 135.807, 0.01}, {100, 149.449, 0.001},
                      {10, 3.940, 0.95},   {100, 77.929, 0.95}};
  for (const Row& r : rows) {
    EXPECT_NEAR(ChiSquareSurvival(r.x, r.dof), r.upper_tail, 2e-4 + 2e-3 * r.upper_tail)
        << "dof " << r.dof << " x " << r.x;
  }
  EXPECT_DOUBLE_EQ(ChiSquareSurvival(0, 5), 1.0);
  EXPECT_LT(ChiSquareSurvival(1000, 100), 1e-100);
}

}  // namespace
}  // namespace omni::health
