// HDF5 traces (haptics/trace_h5.cc): what a file declares is checked before it is allocated.
// Its round trips and mistakes are in trace_test.cc, beside the CSV reader's.

#include <gtest/gtest.h>

#include <string>

#include "engine/errors.h"
#include "engine/input_limits.h"
#include "haptics/h5_declared_rows.h"
#include "haptics/trace.h"
#include "test_data.h"

namespace hapvox::haptics {
namespace {

using ::hapvox::testing::input_error_of;

TEST(TraceH5Budget, DeclaredRowsPastTheLimitAreRefusedBeforeAllocating) {
  const std::string dir = hapvox::testing::scratch_dir();
  // 1.5e9 rows in 2 kB grew past 8 GB; 2^40 rows ended in "internal error: std::bad_alloc".
  const std::string many = dir + "/many.h5";
  ASSERT_TRUE(hapvox::testing::write_h5_declaring_rows(many, 1'500'000'000));
  EXPECT_EQ(input_error_of([&] { read_h5_trace(many); }),
            many +
                ": dataset 't' declares 1500000000 rows, over the limit of 50000000 rows "
                "(raise it with --max-trace-rows)");
  const std::string absurd = dir + "/absurd.h5";
  ASSERT_TRUE(hapvox::testing::write_h5_declaring_rows(absurd, hsize_t{1} << 40));
  EXPECT_EQ(input_error_of([&] { read_trace(absurd); }),
            absurd +
                ": dataset 't' declares 1099511627776 rows, over the limit of 50000000 "
                "rows (raise it with --max-trace-rows)");
}

TEST(TraceH5Budget, TheLimitIsTheProcesssToRaise) {
  const std::string path = hapvox::testing::scratch_dir() + "/three.h5";
  ASSERT_TRUE(hapvox::testing::write_h5_declaring_rows(path, 3));
  engine::InputLimits& limits = engine::input_limits();
  const engine::InputLimits saved = limits;
  limits.max_trace_rows = 2;
  EXPECT_EQ(input_error_of([&] { read_h5_trace(path); }),
            path +
                ": dataset 't' declares 3 rows, over the limit of 2 rows (raise it with "
                "--max-trace-rows)");
  limits.max_trace_rows = 3;  // at the limit: read (its unwritten rows are zeros)
  EXPECT_EQ(input_error_of([&] { read_h5_trace(path); }),
            path + ": index 1: time 0 does not increase (previous 0)");
  limits = saved;
}

}  // namespace
}  // namespace hapvox::haptics
