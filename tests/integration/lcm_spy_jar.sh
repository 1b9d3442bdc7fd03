#!/usr/bin/env bash
# The Java jar that lcm-spy loads holds every evermap type with the same fingerprint as C++.
set -euo pipefail
build="$1"; src="$2"
jar="$build/share/java/evermap_lcmtypes.jar"
[ -f "$jar" ] || { echo "missing $jar"; exit 1; }
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT
javac -nowarn -cp /usr/share/java/lcm.jar -d "$tmp" "$src/tests/java/ListTypes.java"
java -cp "$tmp:/usr/share/java/lcm.jar:$jar" ListTypes "$jar" > "$tmp/java.txt"
"$build/bin/evermap-lcm-check" --list-types | sort > "$tmp/cpp.txt"
n=$(wc -l < "$tmp/cpp.txt")
if ! diff "$tmp/cpp.txt" "$tmp/java.txt"; then
  echo "FAIL: Java and C++ types differ"; exit 1
fi
[ "$n" -ge 20 ] || { echo "FAIL: only $n types"; exit 1; }
echo "OK: $n types agree between C++ and the lcm-spy jar"
