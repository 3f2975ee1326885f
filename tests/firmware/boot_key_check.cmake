# The key embedding of firmware/boot/wdr_boot_key.cmake on its own, as a configure would run it:
#   cmake -DKEY=PUB.pem -DOUT=header.h -DBIN=scratch-dir -P boot_key_check.cmake
set(CMAKE_BINARY_DIR ${BIN})
include(${CMAKE_CURRENT_LIST_DIR}/../../firmware/boot/wdr_boot_key.cmake)
wdr_boot_generate_key(${KEY} ${OUT})
