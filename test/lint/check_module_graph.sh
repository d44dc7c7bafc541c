#!/usr/bin/env bash
# Checks what docs/architecture.md states about the modules, and fails on each breach it prints:
#  1. a core module includes only the modules its row of the module table lets it use;
#  2. each nodelet of nodelet_plugins.xml uses the core through its own stage alone:
#     src/nodelets/<name>_nodelet.cpp includes core/<module>/<name>_stage.h and, besides it,
#     only core/common/ headers;
#  3. nothing under src/ros or src/nodelets includes the testing, runner or simulation modules,
#     and once built (CCIR_WS, default .ws) the nodelets' library does not link libccir_mapping_
#     testing, runner or simulation, directly or through another of the package's libraries.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
table="$root/docs/architecture.md"
failed=0
fail() {
  echo "$*"
  failed=1
}

# 1. The module table: | `module` | `dep`, `dep` | why |
declare -A allowed
while IFS='|' read -r _ module deps _; do
  module="${module//[\` ]/}"
  allowed[$module]=" $(echo "$deps" | tr -d '`,' | xargs) "
done < <(grep -E '^\| `[a-z_]+` \| (`[a-z_]+`(, )?)* ?\|' "$table")
[ "${#allowed[@]}" -gt 0 ] || { echo "no module table in $table"; exit 1; }
files=0
for dir in "$root/include/ccir_mapping/core" "$root/src/core"; do
  for module_dir in "$dir"/*/; do
    module="$(basename "$module_dir")"
    if [ -z "${allowed[$module]+x}" ]; then
      fail "core module '$module' is not in the table of $table"
      continue
    fi
    while IFS= read -r file; do
      files=$((files + 1))
      while IFS= read -r hit; do
        used="$(echo "$hit" | sed -E 's|.*ccir_mapping/core/([a-z_]+)/.*|\1|')"
        if [ "$used" != "$module" ] && [[ "${allowed[$module]}" != *" $used "* ]]; then
          fail "${file#$root/}: $module may not use $used: $hit"
        fi
      done < <(grep -hE '^\s*#\s*include\s*"ccir_mapping/core/[a-z_]+/' "$file" || true)
    done < <(find "$module_dir" -type f)
  done
done

# 2. Each nodelet over its own stage.
nodelets=0
for name in $(sed -nE 's/.*type="ccir_mapping::([A-Za-z]+)Nodelet".*/\1/p' "$root/nodelet_plugins.xml" |
  tr 'A-Z' 'a-z'); do
  file="$root/src/nodelets/${name}_nodelet.cpp"
  nodelets=$((nodelets + 1))
  stage="$(grep -hoE "ccir_mapping/core/[a-z_]+/${name}_stage\.h" "$file" || true)"
  [ -n "$stage" ] || fail "src/nodelets/${name}_nodelet.cpp does not include its stage, core/<module>/${name}_stage.h"
  while IFS= read -r hit; do
    fail "src/nodelets/${name}_nodelet.cpp uses the core beside its stage: $hit"
  done < <(grep -hE '^\s*#\s*include\s*"ccir_mapping/core/' "$file" |
    grep -vE "\"ccir_mapping/core/(common/[a-z_]+|[a-z_]+/${name}_stage)\.h\"" || true)
done

# 3. What a robot runs never carries test, runner or simulation code.
if hits=$(grep -rnE '^\s*#\s*include\s*"ccir_mapping/core/(testing|runner|simulation)/' \
  "$root/src/nodelets" "$root/src/ros" "$root/include/ccir_mapping/ros" |
  grep -v "mission_files"); then
  fail "the ROS layer includes test, runner or simulation code:"$'\n'"$hits"
fi
lib_dir="${CCIR_WS:-$root/.ws}/devel/lib"
linked="not built yet: link not checked"
if [ -f "$lib_dir/libccir_mapping_nodelets.so" ]; then
  declare -A seen
  queue=(libccir_mapping_nodelets.so)
  while ((${#queue[@]})); do
    lib="${queue[0]}"
    queue=("${queue[@]:1}")
    [ -z "${seen[$lib]+x}" ] || continue
    seen[$lib]=1
    [ -f "$lib_dir/$lib" ] || continue
    while IFS= read -r needed; do queue+=("$needed"); done < <(readelf -d "$lib_dir/$lib" |
      sed -nE 's/.*Shared library: \[(libccir_mapping_[a-z_]+\.so)\].*/\1/p')
  done
  for lib in "${!seen[@]}"; do
    case "$lib" in
      libccir_mapping_testing.so | libccir_mapping_runner.so | libccir_mapping_simulation*.so)
        fail "the nodelets' library links $lib" ;;
    esac
  done
  linked="the nodelets link ${#seen[@]} of the package's libraries, none of testing, runner, simulation"
fi
[ "$failed" = 0 ] || exit 1
echo "module graph check: $files core files within docs/architecture.md's table; $nodelets nodelets each over its own stage; $linked"
