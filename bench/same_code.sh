#!/usr/bin/env bash
# Whether a refactoring changed any machine code: compares the disassembly of every object file of
# two build trees (same compiler and flags), matched by file name within the stage and simulator
# modules, where every estimate is computed. Equal code gives equal results, so this stands in for
# re-running paper_tables and the coverage study after a move that should change nothing.
#   bash bench/same_code.sh OLD_BUILD_DIR NEW_BUILD_DIR
set -euo pipefail
old=$1 new=$2
disasm() { objdump -d --no-show-raw-insn -w "$1" | grep -v -e 'file format' -e '^Disassembly' -e '^$' | sed 's/^ *[0-9a-f]*://'; }
same=0 differ=0
for module in core sim; do
  for o in "$new"/src/CMakeFiles/insalign_"$module".dir/"$module"/*.o; do
    b=$(basename "$o")
    prev=$(find "$old"/src/CMakeFiles -path "*/$module/$b" | head -1)
    if [[ -z $prev ]]; then echo "new file: $module/$b"; continue; fi
    if cmp -s <(disasm "$prev") <(disasm "$o"); then same=$((same + 1)); else differ=$((differ + 1)); echo "differs: $module/$b"; fi
  done
done
echo "$same object files with the same code, $differ differ"
