#!/usr/bin/env bash
# Makes LCM (UDP multicast) usable on a machine without a network: adds a multicast route on the
# loopback interface when no route for 224.0.0.0/4 exists. Idempotent; needs root (or sudo) to
# add the route, and only warns without it (the LCM tests then skip with a reason).
set -euo pipefail
if ! command -v ip >/dev/null 2>&1; then
  echo "[lcm-route] 'ip' (iproute2) not found; install it: apt-get install iproute2" >&2
  exit 0
fi
if [ -n "$(ip route show 224.0.0.0/4 2>/dev/null)" ]; then
  exit 0  # a multicast route exists (a real network, or this script ran before)
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    SUDO="sudo -n"
  else
    echo "[lcm-route] no multicast route and not root: LCM tests will skip (as root: ip route add 224.0.0.0/4 dev lo)" >&2
    exit 0
  fi
fi
$SUDO ip link set lo multicast on 2>/dev/null || true
$SUDO ip route add 224.0.0.0/4 dev lo
echo "[lcm-route] added multicast route 224.0.0.0/4 on lo"
