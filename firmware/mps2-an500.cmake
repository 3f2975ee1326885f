# The mps2-an500 images (boards/mps2-an500, hal/mps2), included by firmware/CMakeLists.txt in
# the cortex-m7 build:
#   wdr_fw_mps2.elf         the firmware, linked to run at 0x00020000 where the bootloader
#                           copies it (mps2-an500-app.ld): what `wdrctl fw sign` signs (.bin)
#   wdr_boot_mps2.elf       the bootloader at the reset vector (mps2-an500-boot.ld)
#   wdr_boot_mps2_hashonly.elf  the same without the signature check: only measures what the
#                           check costs (tests/target), never flashed
# each with its .bin and .hex, and the footprint of both side by side (wdr_footprint).
find_program(WDR_OBJCOPY arm-none-eabi-objcopy REQUIRED)

# The application's load range, from the board header (one place for the numbers).
file(STRINGS ${WDR_MPS2_DIR}/mps2_board.h _mps2_app REGEX "^#define MPS2_APP_(BASE|LIMIT) ")
string(REGEX REPLACE ".*MPS2_APP_BASE (0x[0-9a-fA-F]+u).*" "\\1" WDR_MPS2_APP_BASE "${_mps2_app}")
string(REGEX REPLACE ".*MPS2_APP_LIMIT (0x[0-9a-fA-F]+u).*" "\\1" WDR_MPS2_APP_LIMIT "${_mps2_app}")

# .bin and .hex beside the .elf.
function(wdr_mps2_outputs target)
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND ${WDR_OBJCOPY} -O binary $<TARGET_FILE:${target}> ${CMAKE_CURRENT_BINARY_DIR}/${target}.bin
    COMMAND ${WDR_OBJCOPY} -O ihex $<TARGET_FILE:${target}> ${CMAKE_CURRENT_BINARY_DIR}/${target}.hex
    BYPRODUCTS ${CMAKE_CURRENT_BINARY_DIR}/${target}.bin ${CMAKE_CURRENT_BINARY_DIR}/${target}.hex
    VERBATIM)
endfunction()


# The firmware's core again, with uploads held to this board's load range (the range the
# bootloader checks at every boot: nothing it would reject is ever marked pending).
add_library(wdr_fw_core_mps2 STATIC ${WDR_FW_CORE_SOURCES})
target_compile_definitions(wdr_fw_core_mps2 PRIVATE WDR_FW_IMAGE_LOAD_LO=${WDR_MPS2_APP_BASE}
  WDR_FW_IMAGE_LOAD_HI=${WDR_MPS2_APP_LIMIT})
target_link_libraries(wdr_fw_core_mps2 PUBLIC wdr_boot wdr_fw)

add_executable(wdr_fw_mps2 main_arm.c ${PROJECT_SOURCE_DIR}/hal/mps2/hal_mps2.c
  ${PROJECT_SOURCE_DIR}/hal/mps2/hal_mps2_boot.c
  ${PROJECT_SOURCE_DIR}/hal/mps2/psram_nor.c)
set_target_properties(wdr_fw_mps2 PROPERTIES SUFFIX ".elf")
target_include_directories(wdr_fw_mps2 PRIVATE ${WDR_MPS2_DIR})
target_compile_definitions(wdr_fw_mps2 PRIVATE WDR_BOARD_MPS2_AN500)
target_link_libraries(wdr_fw_mps2 PRIVATE wdr_fw_core_mps2 wdr_boot wdr_fw)
target_link_options(wdr_fw_mps2 PRIVATE -T${WDR_MPS2_DIR}/mps2-an500-app.ld
  -Wl,-Map=${CMAKE_CURRENT_BINARY_DIR}/wdr_fw_mps2.map -Wl,--print-memory-usage)
set_property(TARGET wdr_fw_mps2 APPEND PROPERTY LINK_DEPENDS ${WDR_MPS2_DIR}/mps2-an500-app.ld)
add_custom_command(TARGET wdr_fw_mps2 POST_BUILD COMMAND ${WDR_SIZE} $<TARGET_FILE:wdr_fw_mps2> VERBATIM)
wdr_mps2_outputs(wdr_fw_mps2)
set(WDR_RAM_MAP_IMAGES wdr_fw_mps2:4194048:mps2-an500)

foreach(variant wdr_boot_mps2:1 wdr_boot_mps2_hashonly:0)
  string(REPLACE ":" ";" parts ${variant})
  list(GET parts 0 target)
  list(GET parts 1 check_signature)
  add_executable(${target} boot/boot_main_arm.c ${PROJECT_SOURCE_DIR}/hal/mps2/hal_mps2_boot.c
  ${PROJECT_SOURCE_DIR}/hal/mps2/psram_nor.c)
  set_target_properties(${target} PROPERTIES SUFFIX ".elf")
  target_include_directories(${target} PRIVATE ${WDR_MPS2_DIR})
  target_compile_definitions(${target} PRIVATE WDR_BOOT_CHECK_SIGNATURE=${check_signature})
  target_link_libraries(${target} PRIVATE wdr_boot wdr_fw)
  target_link_options(${target} PRIVATE -T${WDR_MPS2_DIR}/mps2-an500-boot.ld
    -Wl,-Map=${CMAKE_CURRENT_BINARY_DIR}/${target}.map -Wl,--print-memory-usage)
  set_property(TARGET ${target} APPEND PROPERTY LINK_DEPENDS ${WDR_MPS2_DIR}/mps2-an500-boot.ld)
  wdr_mps2_outputs(${target})
endforeach()

# Flash and RAM of the bootloader beside the application's (the build prints it; .ci/test too).
add_custom_target(wdr_footprint ALL
  COMMAND sh ${PROJECT_SOURCE_DIR}/firmware/boot/footprint.sh ${WDR_SIZE} $<TARGET_FILE:wdr_boot_mps2>
          $<TARGET_FILE:wdr_boot_mps2_hashonly> $<TARGET_FILE:wdr_fw_mps2>
  DEPENDS wdr_boot_mps2 wdr_boot_mps2_hashonly wdr_fw_mps2 VERBATIM)
