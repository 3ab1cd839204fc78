# shellcheck shell=sh disable=SC2154,SC2034 # variables shared with the caller
# SPDX-License-Identifier: MIT
# Sourced by mk/gen-docs.sh, mk/gen-regmap-doc.sh and mk/gen-config-doc.sh: a
# document whose text between two marker lines is generated from the code, the prose around it
# written by hand. The caller sets
#   doc    the document            label  its name in messages and RESULTS
#   begin  the first marker line   end    the last marker line
#   blank  1: an empty line after the begin marker (0: the text brings it)
#   source what generates the text, and the make target that rewrites it
#   tool   the program argument's name in the usage line
# calls doc_args "$@" (sets mode and bin from --write BIN | --check BIN
# RESULTS), generates the text, and calls doc_between MODE GENERATED
# [RESULTS]. A document with a second generated block renders the first
# one into a copy with doc_render, points `doc` at that copy and `target`
# at the document, and calls doc_between for the second one.

doc_args() {
    if [ $# -lt 2 ] || { [ "$1" != --write ] && [ "$1" != --check ]; } ||
       { [ "$1" = --check ] && [ $# -lt 3 ]; }; then
        echo "usage: $0 --write $tool | --check $tool RESULTS" >&2
        exit 2
    fi
    mode=$1 bin=$2
}

# Print the document with the text between the markers replaced by $1.
doc_render() {
    n_begin=$(grep -cxF -- "$begin" "$doc" || true)
    n_end=$(grep -cxF -- "$end" "$doc" || true)
    if [ "$n_begin" != 1 ] || [ "$n_end" != 1 ]; then
        echo "$label: $doc must hold each marker line exactly once:" >&2
        echo "  $begin" >&2
        echo "  $end" >&2
        return 1
    fi
    awk -v begin="$begin" -v end="$end" -v gen="$1" -v blank="$blank" '
        $0 == begin { print; if (blank) print ""
                      while ((getline line < gen) > 0) print line
                      skip = 1; next }
        $0 == end   { print ""; skip = 0 }
        !skip       { print }
    ' "$doc"
}

# --write: replace the document if it changed. --check: compare, and add
# "1 0 LABEL" or "0 1 LABEL" to RESULTS. Exits 1 on a failure.
doc_between() {
    target=${target:-$doc}
    rendered=$(mktemp)
    if ! doc_render "$2" >"$rendered"; then
        rm -f "$rendered"
        [ "$1" != --check ] || { mkdir -p "$(dirname "$3")"; echo "0 1 $label" >>"$3"; }
        exit 1
    fi
    case $1 in
    --write)
        if cmp -s "$rendered" "$target"; then
            echo "$label: $target is up to date"
        else
            cp "$rendered" "$target"
            echo "$label: regenerated the tables in $target"
        fi
        ;;
    --check)
        mkdir -p "$(dirname "$3")"
        if cmp -s "$rendered" "$target"; then
            echo "$label: $target matches $source"
            echo "1 0 $label" >>"$3"
        else
            echo "$label: FAIL: $target differs from what $source gives" >&2
            echo "$label: (- is the document, + is the generated text)" >&2
            diff -u "$target" "$rendered" | sed 's/^/    /' >&2 || true
            echo "0 1 $label" >>"$3"
            rm -f "$rendered"
            exit 1
        fi
        ;;
    esac
    rm -f "$rendered"
}
