#!/usr/bin/env bash
# Fails when a C++ file differs from .clang-format (Google base, 100 columns).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
mapfile -t files < <(find include src test -name '*.h' -o -name '*.cpp' | sort)
clang-format --dry-run --Werror "${files[@]}"
echo "format check: ${#files[@]} files match .clang-format"
