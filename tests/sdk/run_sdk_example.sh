#!/usr/bin/env bash
# The SDK as an out-of-tree plugin author sees it: install the "sdk"
# component of this build into a fresh prefix, configure and build
# examples/plugin-minimal against that prefix only (find_package), then load
# the plugin through the daemon's PluginHost (sdk_example_host).
#
#   run_sdk_example.sh <build dir> <source dir> <sdk_example_host> [sanitizer flags]
set -euo pipefail
build=$1 src=$2 host=$3 sanitize=${4:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cmake --install "$build" --prefix "$tmp/prefix" --component sdk
# The prefix holds exactly the SDK's headers (sdk/include) and nothing of
# the daemon's.
test -f "$tmp/prefix/include/cobridge/plugin.h"
test -f "$tmp/prefix/include/cobridge/emcy.h"
installed=$(cd "$tmp/prefix/include" && find . -type f | sort)
expected=$(cd "$src/sdk/include" && find . -type f | sort)
if [ "$installed" != "$expected" ]; then
  echo "run_sdk_example: the SDK installed other headers than sdk/include holds:" >&2
  diff <(echo "$expected") <(echo "$installed") >&2 || true
  exit 1
fi
cmake -S "$src/examples/plugin-minimal" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_FLAGS="$sanitize" -DCMAKE_MODULE_LINKER_FLAGS="$sanitize" \
      -DCMAKE_SHARED_LINKER_FLAGS="$sanitize" >/dev/null
cmake --build "$tmp/build"
COBRIDGE_SDK_EXAMPLE_DIR="$tmp/build" "$host" --gtest_color=no
