#!/usr/bin/env bash
# Prints one line describing this machine, for benchmark result files.
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
mem=$(awk '/MemTotal/ {printf "%.1f GiB", $2/1048576}' /proc/meminfo)
echo "$(date -u +%Y-%m-%dT%H:%M:%SZ) host=$(hostname) cpu=\"${cpu}\" cores=$(nproc) mem=${mem} os=\"$(. /etc/os-release; echo $PRETTY_NAME)\" compiler=\"$(c++ --version | head -1)\""
