#!/usr/bin/env bash
# The public API is small and standard (issue 14): every header under INCLUDE_DIR/hapvox
# compiles alone in a fresh translation unit with -Wall -Wextra -Wpedantic -Werror, and none
# brings in an OpenVDB, Eigen, HDF5 or TBB header (the -H list of what it included).
# Usage: check_headers.sh CXX INCLUDE_DIR [MORE_INCLUDE_DIRS...]
set -euo pipefail
cxx=$1
shift
flags=()
for dir in "$@"; do flags+=(-I "$dir"); done
headers=()
for dir in "$@"; do
  for h in "$dir"/hapvox/*.h; do [ -e "$h" ] && headers+=("$(basename "$h")"); done
done
[ ${#headers[@]} -gt 0 ] || { echo "no headers under $*/hapvox" >&2; exit 1; }
failed=0
for h in "${headers[@]}"; do
  if ! included=$(printf '#include <hapvox/%s>\nint main() { return 0; }\n' "$h" |
    "$cxx" -std=c++20 -Wall -Wextra -Wpedantic -Werror -fsyntax-only -H -x c++ "${flags[@]}" - 2>&1); then
    echo "hapvox/$h does not compile alone:" >&2
    echo "$included" >&2
    failed=1
    continue
  fi
  if leaked=$(grep -E '(openvdb|[Ee]igen|hdf5|H5[A-Za-z]*\.h|tbb)' <<<"$included"); then
    echo "hapvox/$h includes a dependency's header:" >&2
    echo "$leaked" >&2
    failed=1
  fi
done
[ $failed -eq 0 ] && echo "${#headers[@]} headers compile alone with -Werror; none includes OpenVDB, Eigen, HDF5 or TBB"
exit $failed
