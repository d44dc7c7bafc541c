#!/usr/bin/env bash
# Fails when a core module includes a header of a module that docs/architecture.md's table does
# not let it use. Prints each offending line.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
table="$root/docs/architecture.md"
declare -A allowed
# Rows of the module table: | `module` | `dep`, `dep` | why |
while IFS='|' read -r _ module deps _; do
  module="${module//[\` ]/}"
  allowed[$module]=" $(echo "$deps" | tr -d '`,' | xargs) "
done < <(grep -E '^\| `[a-z_]+` \| (`[a-z_]+`(, )?)* ?\|' "$table")
[ "${#allowed[@]}" -gt 0 ] || { echo "no module table in $table"; exit 1; }
failed=0
files=0
for dir in "$root/include/ccir_mapping/core" "$root/src/core"; do
  for module_dir in "$dir"/*/; do
    module="$(basename "$module_dir")"
    if [ -z "${allowed[$module]+x}" ]; then
      echo "core module '$module' is not in the table of $table"
      failed=1
      continue
    fi
    while IFS= read -r file; do
      files=$((files + 1))
      while IFS= read -r hit; do
        used="$(echo "$hit" | sed -E 's|.*ccir_mapping/core/([a-z_]+)/.*|\1|')"
        if [ "$used" != "$module" ] && [[ "${allowed[$module]}" != *" $used "* ]]; then
          echo "${file#$root/}: $module may not use $used: $hit"
          failed=1
        fi
      done < <(grep -hE '^\s*#\s*include\s*"ccir_mapping/core/[a-z_]+/' "$file" || true)
    done < <(find "$module_dir" -type f)
  done
done
[ "$failed" = 0 ] || exit 1
echo "module graph check: $files files, every include allowed by docs/architecture.md"
