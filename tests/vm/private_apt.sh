# Sourced: apt-get and apt-cache on a private sources list, package lists and cache in a folder
# of the build tree, so that another suite (bookworm-backports, trixie) can be downloaded from
# without touching the system's sources, lists or cache.
#   papt_init DIR "deb http://deb.debian.org/debian SUITE main"   (sets PAPT, runs update)
#   papt_get download PKG...   papt_cache depends PKG
# papt_init returns 1 when the update fails (no mirror).
papt_init() {
    local dir=$1
    shift
    mkdir -p "$dir/lists/partial" "$dir/cache/archives/partial"
    printf '%s\n' "$@" >"$dir/sources.list"
    PAPT="-o Dir::Etc::sourcelist=$dir/sources.list -o Dir::Etc::sourceparts=/dev/null
          -o Dir::State::Lists=$dir/lists -o Dir::Cache=$dir/cache -o APT::Get::List-Cleanup=0
          -o APT::Sandbox::User=root -o Debug::NoLocking=1"
    # Fresh lists once a day at most: the suites move, the test should follow them.
    if [ -z "$(find "$dir/lists" -maxdepth 1 -name '*Packages*' -mtime -1 2>/dev/null)" ]; then
        # shellcheck disable=SC2086
        apt-get -qq $PAPT update >&2 || return 1
    fi
}
# shellcheck disable=SC2086
papt_get() { apt-get -q $PAPT "$@"; }
# shellcheck disable=SC2086
papt_cache() { apt-cache $PAPT "$@"; }
