#!/bin/sh
# Flash and RAM of Cortex-M7 images side by side, from arm-none-eabi-size's Berkeley output:
# flash = text + data (the initial values of .data are stored with the code), RAM = data + bss
# (the stack is the rest of the RAM region, sized by the linker script).
#   footprint.sh SIZE ELF...
size=$1
shift
printf '%-28s %10s %10s\n' image "flash (B)" "RAM (B)"
"$size" "$@" | awk 'NR > 1 { n = split($6, p, "/"); printf "%-28s %10d %10d\n", p[n], $1 + $2, $2 + $3 }'
