#!/usr/bin/env bash
# Builds the packages (build_scripts/package.sh), then installs the right one into a clean user
# directory of every Blender named in $QUATCURVE_BLENDERS (NAME=COMMAND;…) and bakes once.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
"$ROOT/build_scripts/package.sh"
version="$(sed -n 's/^version = "\(.*\)"/\1/p' "$ROOT/addon/quatcurve_blender/blender_manifest.toml")"
passed=0 failed=0
IFS=';' read -ra blenders <<< "${QUATCURVE_BLENDERS:?set QUATCURVE_BLENDERS}"
for entry in "${blenders[@]}"; do
  name="${entry%%=*}" cmd="${entry#*=}"
  user="$(mktemp -d)"
  if [ "$(basename "$cmd")" = blender ]; then
    zip="$ROOT/dist/quatcurve_blender-$version-legacy-cp311.zip"
    run=(env PATH=/usr/local/bin:/usr/bin:/bin BLENDER_USER_SCRIPTS="$user/scripts" BLENDER_USER_CONFIG="$user/config"
         "$cmd" --background --factory-startup --python-exit-code 1 --python "$ROOT/tests/package/install_and_bake.py" -- "$zip")
  else
    zip="$ROOT/dist/quatcurve_blender-$version-extension.zip"
    run=(env BLENDER_USER_RESOURCES="$user" "$cmd" "$ROOT/tests/package/install_and_bake.py" "$zip")
  fi
  if (cd "$user" && "${run[@]}") > "$user.log" 2>&1; then
    passed=$((passed + 1)); echo "package/$name: $(grep '^baked:' "$user.log")"
  else
    failed=$((failed + 1)); echo "package/$name FAILED:"; tail -20 "$user.log"
  fi
  rm -rf "$user" "$user.log"
done
echo "package: $passed passed, $failed failed"
[ "$failed" = 0 ]
