#pragma once
// input_error_of moved to test_data.h (haptics_tests uses it too). This header only forwards
// there, for tests written against it (tests/engine/proxy, in progress on another branch);
// include test_data.h instead, and delete this once nothing includes it.

#include "test_data.h"
