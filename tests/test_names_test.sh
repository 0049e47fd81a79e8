#!/usr/bin/env bash
# CTest runs each doctest case by name (doctest_discover_tests). A name with
# ';' is split by CMake and one with '[' or ']' is read as a pattern: such a
# case matches nothing and "passes" without running. Refuse those names.
set -euo pipefail
cd "$(dirname "$0")/.."
bad=$(grep -rnE 'TEST_CASE\("[^"]*[];[]' --include='*.cpp' util targets metrology reports cli tests || true)
if [ -n "$bad" ]; then
  echo "test names that CTest cannot run (they contain ';', '[' or ']'):"
  echo "$bad"
  exit 1
fi
echo "test names: all runnable by CTest"
