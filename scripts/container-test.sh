#!/usr/bin/env bash
# Check containers/Dockerfile without a Docker engine: carry out its instructions in a Debian root
# filesystem made by debootstrap, then run the serial test suite whole, check's part on two ranks
# (`make test-container`) and one `mpirun -n 2` paper run there. CONTAINER_DOCKERFILE=
# containers/Dockerfile.sid checks another recipe (its ignore file is the one BuildKit reads:
# containers/Dockerfile.sid.dockerignore).
#
#   FROM debian:<suite>    debootstrap --variant=minbase <suite> build/<suite> (kept for the next
#                          run; CONTAINER_FRESH=1 makes it again)
#   ENV NAME=value         the environment of every later step (env -i: nothing leaks from here)
#   ARG NAME=value         the same, for later RUN steps only
#   WORKDIR, COPY . <dir>  the current checkout copied to <dir>, without what
#                          containers/Dockerfile.dockerignore leaves out (the host's .venv above all)
#   RUN <command>          sh -c <command> in the chroot, with /proc, /sys and /dev mounted
#   ENTRYPOINT ["<path>"]  the command of the paper run
#
# The chroot's copy is made anew on every run, so the current tree is installed and tested. The
# whole script runs in a private mount namespace and unmounts on exit, failure or Ctrl-C alike.
set -euo pipefail
self=$(realpath "$0")
cd "$(dirname "$self")/.."
repo=$PWD
dockerfile=${CONTAINER_DOCKERFILE:-containers/Dockerfile}
ignorefile=$dockerfile.dockerignore # BuildKit's name for the ignore file of this Dockerfile
mirror=${CONTAINER_MIRROR:-http://deb.debian.org/debian}

say() { printf 'container-test: %s\n' "$*"; }
die() { printf 'container-test: %s\n' "$*" >&2; exit 1; }

[ "$(id -u)" = 0 ] || die "needs root (debootstrap, mount, chroot)"
[ -f "$dockerfile" ] || die "no Dockerfile $dockerfile"
[ -f "$ignorefile" ] || die "no ignore file $ignorefile next to $dockerfile"
if [ -z "${RODFEM_CONTAINER_TEST_NS:-}" ]; then
  # Mounts made in a private namespace vanish with it, even if this script is killed.
  exec env RODFEM_CONTAINER_TEST_NS=1 unshare --mount --propagation private "$self" "$@"
fi

# --- The Dockerfile, instruction by instruction (only the subset this script can carry out). ---
from='' steps=() entrypoint=''
while IFS= read -r line || [ -n "$line" ]; do
  case $line in '' | '#'*) continue ;; esac
  [[ $line == *\\ ]] && die "$dockerfile: continuation lines are not supported: $line"
  instruction=${line%% *} argument=${line#* }
  case $instruction in
    FROM) [[ $argument =~ ^debian:([a-z]+)$ ]] || die "$dockerfile: FROM must be debian:<suite>"
      from=${BASH_REMATCH[1]} ;;
    ARG | ENV) [[ $argument =~ ^[A-Za-z_][A-Za-z0-9_]*=[^[:space:]\"\'\$]*$ ]] ||
      die "$dockerfile: only $instruction NAME=value (no quotes, spaces or \$): $line"
      steps+=("$instruction $argument") ;;
    WORKDIR) [[ $argument =~ ^(/[A-Za-z0-9_][A-Za-z0-9_-]*)+$ ]] ||
      die "$dockerfile: WORKDIR must be a plain absolute path: $line"
      steps+=("WORKDIR $argument") ;;
    COPY) [[ $argument =~ ^\.\ ((/[A-Za-z0-9_][A-Za-z0-9_-]*)+)$ ]] ||
      die "$dockerfile: only COPY . /plain/absolute/dir: $line"
      steps+=("COPY ${BASH_REMATCH[1]}") ;;
    RUN) [[ $argument == \[* ]] && die "$dockerfile: only the shell form of RUN: $line"
      steps+=("RUN $argument") ;;
    ENTRYPOINT) [[ $argument =~ ^\[\"(/[^\"]+)\"\]$ ]] ||
      die "$dockerfile: ENTRYPOINT must be [\"/absolute/path\"]"
      entrypoint=${BASH_REMATCH[1]} ;;
    CMD) ;;
    *) die "$dockerfile: instruction $instruction is not supported here" ;;
  esac
done <"$dockerfile"
{ [ -n "$from" ] && [ -n "$entrypoint" ]; } || die "$dockerfile: needs FROM and ENTRYPOINT"

rootfs=$(realpath -m "$repo/build/$from") # as /proc/self/mounts spells it
mkdir -p "$repo/build"
# The installed root filesystem takes about 3 GB; a full disk fails halfway with odd errors.
free_kb=$(df --output=avail -k "$repo/build" | tail -1)
((free_kb > 5000000)) || die "less than 5 GB free under build/ ($((free_kb / 1024)) MB)"
mounted() { grep -q " $1[/ ]" /proc/self/mounts; }
timed() { # timed LABEL COMMAND...: run it and report its wall time; its exit status
  local label=$1 start status=0
  shift
  start=$(date +%s%N)
  "$@" || status=$?
  say "$label: $(((($(date +%s%N) - start) / 100000000 + 5) / 10)) s$( ((status)) && echo ", failed")"
  return "$status"
}

# --- FROM: the root filesystem. ---
if [ -n "${CONTAINER_FRESH:-}" ] && [ -d "$rootfs" ]; then
  mounted "$rootfs" && die "something is mounted under $rootfs; not removing it"
  rm -rf "$rootfs"
fi
if [ ! -d "$rootfs" ]; then
  if ! command -v debootstrap >/dev/null; then
    say "apt-get install debootstrap"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends debootstrap \
      >/dev/null
  fi
  mounted "$rootfs.partial" && die "something is mounted under $rootfs.partial"
  rm -rf "$rootfs.partial"
  say "debootstrap --variant=minbase $from $rootfs $mirror"
  log=$repo/build/debootstrap-$from.log
  logged() { "$@" >"$log" 2>&1; }
  timed "debootstrap $from" logged debootstrap --variant=minbase "$from" "$rootfs.partial" \
    "$mirror" || die "debootstrap failed; see ${log#"$repo/"}"
  # The sources of Debian's image: the release, its updates and security; unstable (sid) has
  # neither updates nor security suites, and its image lists sid alone.
  rm -f "$rootfs.partial/etc/apt/sources.list"
  case $from in
    sid | unstable) cat >"$rootfs.partial/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $mirror
Suites: $from
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
      # sid's Release file carries a Valid-Until a week ahead and the mirror reachable here serves
      # one past it, which apt-get update refuses ("is expired"). Debootstrap does not check it;
      # apt in the chroot is told not to (Debian's own image needs no such file).
      echo 'Acquire::Check-Valid-Until "false";' \
        >"$rootfs.partial/etc/apt/apt.conf.d/99-container-test-no-valid-until" ;;
    *) cat >"$rootfs.partial/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $mirror
Suites: $from $from-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: http://deb.debian.org/debian-security
Suites: $from-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
      ;;
  esac
  # As in Debian's images: no .deb files kept after installing, no translations.
  cat >"$rootfs.partial/etc/apt/apt.conf.d/docker-clean" <<'EOF'
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
EOF
  echo 'Acquire::Languages "none";' >"$rootfs.partial/etc/apt/apt.conf.d/docker-no-languages"
  # No daemons started by package scripts inside the chroot (they would keep its /dev busy).
  printf '#!/bin/sh\nexit 101\n' >"$rootfs.partial/usr/sbin/policy-rc.d"
  chmod +x "$rootfs.partial/usr/sbin/policy-rc.d"
  mv "$rootfs.partial" "$rootfs"
else
  say "reusing $rootfs (CONTAINER_FRESH=1 makes it again)"
fi

# --- The chroot: network from the host, /proc, /sys and /dev mounted until this script ends. ---
rm -f "$rootfs/etc/resolv.conf" # a symlink here would point into the host's /run
cp -L /etc/resolv.conf "$rootfs/etc/resolv.conf"
# Certificate authorities the host's administrator added (a TLS-inspecting proxy's, say): Debian's
# ca-certificates takes them into the chroot's bundle when it is installed or updated.
mkdir -p "$rootfs/usr/local/share/ca-certificates"
if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
  cp /usr/local/share/ca-certificates/*.crt "$rootfs/usr/local/share/ca-certificates/"
  if [ -x "$rootfs/usr/sbin/update-ca-certificates" ]; then
    chroot "$rootfs" /usr/sbin/update-ca-certificates >"$repo/build/ca-certificates.log" 2>&1 ||
      die "update-ca-certificates failed in the chroot; see build/ca-certificates.log"
  fi
fi
mounts=()
unmount_all() {
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[i]}" 2>/dev/null || umount -l "${mounts[i]}" || true
  done
  mounts=()
}
trap unmount_all EXIT
trap 'exit 130' INT TERM
mount_in() { # mount_in TARGET MOUNT-ARGS...
  local target=$rootfs$1
  shift
  mkdir -p "$target"
  mount "$@" "$target"
  mounts+=("$target")
}
mount_in /proc -t proc proc
mount_in /sys --bind /sys
mount_in /dev --bind /dev
mount_in /dev/pts --bind /dev/pts
[ -d /dev/shm ] && mount_in /dev/shm --bind /dev/shm

# Docker's defaults, then the Dockerfile's ARG/ENV as they come.
environment=(PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin HOME=/root
  HOSTNAME=rodfem-container-test)
for name in http_proxy https_proxy no_proxy HTTP_PROXY HTTPS_PROXY NO_PROXY; do
  [ -z "${!name:-}" ] || environment+=("$name=${!name}") # the host's network, as docker build
done
build_args=() workdir=/
chroot=$(command -v chroot)
in_chroot() { # in_chroot COMMAND: sh -c COMMAND in the workdir, with only the image's environment
  env -i "${build_args[@]}" "${environment[@]}" "$chroot" "$rootfs" \
    /bin/sh -c "cd \"\$1\" && $1" sh "$workdir"
}

# --- The Dockerfile's steps. ---
for step in "${steps[@]}"; do
  instruction=${step%% *} argument=${step#* }
  case $instruction in
    ENV) environment+=("$argument") ;;
    ARG) build_args+=("$argument") ;;
    WORKDIR) workdir=$argument
      mkdir -p "$rootfs$workdir" ;;
    COPY) # the checkout as the build context, less the ignore file's patterns
      excludes=()
      while IFS= read -r pattern || [ -n "$pattern" ]; do
        case $pattern in '' | '#'*) continue ;; esac
        [[ $pattern == '!'* ]] && die "$ignorefile: exceptions (!) are not supported"
        if [[ $pattern == '**/'* ]]; then
          excludes+=(--no-anchored "--exclude=${pattern#'**/'}")
        else
          excludes+=(--anchored "--exclude=./$pattern")
        fi
      done <"$ignorefile"
      say "COPY . $argument"
      mounted "$rootfs$argument" && die "something is mounted under $rootfs$argument"
      rm -rf "$rootfs$argument"
      mkdir -p "$rootfs$argument"
      tar -C "$repo" "${excludes[@]}" -cf - . | tar -C "$rootfs$argument" -xf -
      [ ! -e "$rootfs$argument/.venv" ] || die "the host's .venv was copied" ;;
    RUN) say "RUN $argument"
      timed "RUN (install)" in_chroot "$argument" ;;
  esac
done
build_args=() # build time only

# --- The suite and a paper run, in the installed image. ---
[ -x "$rootfs$entrypoint" ] || die "ENTRYPOINT $entrypoint is not an executable in the image"
say "make test-container"
timed "make test-container" in_chroot "make test-container"
say "mpirun -n 2 $entrypoint run paper1"
out=/tmp/rodfem-container-test/paper1
timed "mpirun -n 2 paper1" in_chroot "rm -rf $out && mpirun -n 2 $entrypoint run paper1 --out $out"
grep -q '"status": "complete"' "$rootfs$out/summary.json" || die "paper1 did not complete"
versions=$(in_chroot "$workdir/.venv/bin/python -c 'import dolfinx, numpy, sys
print(f\"dolfinx {dolfinx.__version__}, numpy {numpy.__version__}, python {sys.version.split()[0]}\")'")
say "passed on Debian $(cat "$rootfs/etc/debian_version") ($versions)"
