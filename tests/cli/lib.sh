# Helpers of the command tests: source it, then call check/refuse, then finish.
#   $tesswave: the binary; $dir: a private temporary folder, removed on exit.
set -uo pipefail
tesswave=$1
dir=$(mktemp -d "${TMPDIR:-/tmp}/tesswave-cli.XXXXXX")
trap 'rm -rf "$dir"' EXIT
failures=0 passes=0
pass() {
    echo "ok: $1"
    passes=$((passes + 1))
}
fail() {
    echo "FAILED: $1"
    failures=$((failures + 1))
}
check() {  # check DESCRIPTION COMMAND...: the command must succeed
    local what=$1
    shift
    if "$@" >"$dir/out.txt" 2>"$dir/err.txt"; then
        pass "$what"
    else
        fail "$what (exit $?): $(head -c 400 "$dir/err.txt")"
    fi
}
refuse() {  # refuse DESCRIPTION OUTPUT COMMAND...: exit 2, one line on stderr, no OUTPUT
    local what=$1 output=$2 status=0
    shift 2
    "$@" >"$dir/out.txt" 2>"$dir/err.txt" || status=$?
    if ((status == 2)) && [[ ! -e $output ]] && (($(wc -l <"$dir/err.txt") == 1)); then
        pass "$what refused: $(cat "$dir/err.txt")"
    else
        fail "$what: exit $status, output exists: $([[ -e $output ]] && echo yes || echo no)"
    fi
}
finish() {
    echo "$passes passed, $failures failed"
    exit $((failures > 0))
}
