#!/usr/bin/env bash
# Fails when `rosrun ccir_mapping TOOL --help` prints anything the tool itself does not (e.g.
# find's "File system loop detected" while rosrun searches a package directory that links back
# into itself), for every tool the workspace (CCIR_WS, default .ws) has built. Needs the
# workspace sourced (scripts/test does).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
bin="${CCIR_WS:-$root/.ws}/devel/lib/ccir_mapping"
[ -d "$bin" ] || { echo "not built: $bin"; exit 1; }
tools=0
failed=0
for tool in "$bin"/*; do
  name="$(basename "$tool")"
  [ -x "$tool" ] && [ -f "$tool" ] || continue
  case "$name" in *_tests | *_check | *.so) continue ;; esac
  tools=$((tools + 1))
  direct="$("$tool" --help 2>&1 || true)"
  via_rosrun="$(rosrun ccir_mapping "$name" --help 2>&1 || true)"
  if [ "$direct" != "$via_rosrun" ]; then
    echo "rosrun ccir_mapping $name prints more than the tool:"
    diff <(echo "$direct") <(echo "$via_rosrun") | head -10
    failed=1
  fi
done
[ "$failed" = 0 ] || exit 1
echo "rosrun check: $tools tools print through rosrun exactly what they print themselves"
