#!/usr/bin/env sh
# Runs `sh -c SCRIPT` where DDS cannot leave this machine (the ROS 2 tests, tests/tests/ros2.rs):
# in a private network namespace with only `lo` when this user may make one (`unshare -n`, as
# root in CI), otherwise on this machine's interfaces with both sides held to loopback
# (cyclonedds through tests/ros2/cyclonedds-lo.xml, `lives ros2 --localhost`), which the
# script must do anyway. Prints which on stderr.
#
#   tests/ros2/netns.sh 'lives ros2 --localhost ... & python3 ...; wait'
set -eu
here="$(cd "$(dirname "$0")" && pwd)"
export CYCLONEDDS_URI="file://$here/cyclonedds-lo.xml"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
if [ "${LIVES_ROS2_NO_NETNS:-0}" != 1 ] && command -v ip >/dev/null && unshare -n true 2>/dev/null; then
    exec unshare -n sh -c 'ip link set lo up && exec sh -c "$0"' "$1"
fi
echo "netns.sh: no private network namespace (unshare -n refused): DDS held to loopback by configuration" >&2
exec sh -c "$1"
