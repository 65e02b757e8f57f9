#!/usr/bin/env bash
# Checks that the repository's docs hold every rule its comments cite, and that the algorithm page
# names only what exists. Over the files git tracks:
#  - every "§N" or "§N.M" (the project cites docs/ALGORITHM.md as "ALGORITHM.md §4.5"; § stands
#    for nothing else) is a numbered section of docs/ALGORITHM.md;
#  - nothing cites the specification the project was started from, which is not in the repository,
#    nor any other page that is not (every "NAME.md" named is a Markdown file of the repository);
#  - every test docs/ALGORITHM.md names (`Suite.Name`) is a test in tests/, every identifier it
#    names in backquotes (`refinePoint`, `Refiner::points`) occurs in the code, and every path it
#    names exists.
# Prints one line per problem ("file:line: what") and exits with status 1 when there is any.
# Needs git and GNU grep; reads only, from any directory.
set -euo pipefail
cd "$(dirname "$0")/.."
doc=docs/ALGORITHM.md
self=scripts/check-docs.sh
problems=0
problem() {
    echo "$1"
    problems=$((problems + 1))
}

# "## 4. Local refinement" -> 4, "### 4.5 Step 5" -> 4.5.
declare -A section
while read -r number; do section[$number]=1; done < <(grep -oE '^#{2,3} [0-9]+(\.[0-9]+)?' "$doc" |
    grep -oE '[0-9]+(\.[0-9]+)?$')

while IFS= read -r hit; do
    file=${hit%%:*}
    rest=${hit#*:}
    line=${rest%%:*}
    cited=${rest#*:§}
    [ -n "${section[$cited]:-}" ] || problem "$file:$line: cites ALGORITHM.md §$cited, which $doc does not have"
done < <(git grep -I -n -o -E '§[0-9]+(\.[0-9]+)*' -- . ":!$self" || true)

while IFS= read -r hit; do
    problem "${hit%%:*}:$(cut -d: -f2 <<<"$hit"): cites SPEC, which is not in the repository: cite $doc"
done < <(git grep -I -n -E '\bSPEC( [0-9]|\.md)' -- . ":!$self" || true)

declare -A page
while read -r path; do page[${path##*/}]=1; done < <(git ls-files '*.md')
while IFS= read -r hit; do
    name=${hit##*:}
    [ -n "${page[$name]:-}" ] || [ "$name" = SPEC.md ] ||
        problem "${hit%:*}: names $name, which is not in the repository"
done < <(git grep -I -n -o -E '\b[A-Za-z_-]+\.md\b' -- . ":!$self" || true)

# Names in backquotes on the page, with the line they are on, against the code's words and tests.
declare -A word test
while read -r w; do word[$w]=1; done < <(git grep -h -o -w -E '[A-Za-z_][A-Za-z0-9_]*' -- \
    refine engine tools shaders tests scripts | sort -u)
while read -r t; do test[$t]=1; done < <(git grep -h -o -E 'TEST(_F|_P)?\([A-Za-z0-9_]+, [A-Za-z0-9_]+\)' -- tests |
    sed -E 's/^TEST(_F|_P)?\(([^,]+), ([^)]+)\)$/\2.\3/')
# shellcheck disable=SC2016 # backquotes, not an expansion
names=$(grep -n -o -E '`[^`]+`' "$doc" | tr -d '`')
while IFS=: read -r line name; do
    if [[ $name =~ ^[A-Z][A-Za-z0-9]*\.[A-Z][A-Za-z0-9]*$ ]]; then
        [ -n "${test[$name]:-}" ] || problem "$doc:$line: names the test $name, which tests/ does not have"
    elif [[ $name =~ ^[A-Za-z_][A-Za-z0-9_]*(::[A-Za-z_][A-Za-z0-9_]*)*(\(\))?$ ]]; then
        last=${name%()}
        last=${last##*::}
        [ -n "${word[$last]:-}" ] || problem "$doc:$line: names $name, which the code does not have"
    elif [[ $name =~ ^[A-Za-z0-9_./-]+/[A-Za-z0-9_.-]+\.(h|cpp|glsl|comp|frag|vert|md|sh)$ ]]; then
        [ -e "$name" ] || problem "$doc:$line: names the file $name, which does not exist"
    fi
done <<<"$names"

if [ "$problems" -gt 0 ]; then
    echo "check-docs: $problems problem(s)" >&2
    exit 1
fi
echo "check-docs: every cited section and page exists; every test, name and file $doc names exists"
