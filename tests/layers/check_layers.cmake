# The layer check: every #include "..." in the product's sources must point to its own folder or
# to a layer below. Run as `cmake -DSOURCE_DIR=<repo> -P check_layers.cmake`; prints the include
# graph by folder (edge: count) and fails on the first upward or sideways edge it lists.
#
# Layers, bottom first (README.md draws the same picture):
#   0 firmware/ and hal/hal.h      the bare-metal core and the one board contract
#   1 sim/                         the physics: boards, device equations, scenes, the simulator
#   2 hal/<backend>/               one backend per folder; a backend never includes another
#   3 host/lib/                    operators, ramps, tone maps, transports
#   4 host/cal/<stage>/            calibration, one folder per pipeline stage (their order among
#                                  themselves: check_cal_stages.cmake)
#   5 host/study/                  the study of what accuracy costs (wdrctl study)
#   6 programs                     wdrctl, wdrsim, wdr-simboard (host/simboard), wdr-board
#                                  (host/board), the firmware images
# Programs may include anything below them. The listed program files outside the program
# folders are the firmware images' mains; none may be in hal/: a backend includes nothing above
# it, so the board programs live in host/simboard and host/board (a main left in hal/ is
# checked as the backend it sits in, and its includes of host/ fail).
include(${CMAKE_CURRENT_LIST_DIR}/layer_report.cmake)
set(layer_firmware 0)
set(layer_firmware/boot 0)
set(layer_hal 0)
set(layer_sim 1)
set(layer_hal/sim 2)
set(layer_hal/linux 2)
set(layer_hal/template 2)
set(layer_hal/mps2 2)
set(layer_host/lib 3)
foreach(stage acquire stats fit table metrics)
  set(layer_host/cal/${stage} 4)
endforeach()
set(layer_host/study 5)
set(layer_host/wdrctl 6)
set(layer_host/wdrsim 6)
set(layer_host/simboard 6)
set(layer_host/board 6)
set(PROGRAMS firmware/main_arm.c firmware/boot/boot_main_arm.c)

if(NOT SOURCE_DIR)
  message(FATAL_ERROR "usage: cmake -DSOURCE_DIR=<repo> -P check_layers.cmake")
endif()
file(GLOB_RECURSE sources RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/firmware/*.[ch] ${SOURCE_DIR}/hal/*.[ch] ${SOURCE_DIR}/sim/*.[ch] ${SOURCE_DIR}/host/*.[ch]
     ${SOURCE_DIR}/host/*.cpp ${SOURCE_DIR}/sim/*.cpp)

# Where each header lives: basename -> folder.
foreach(f ${sources})
  if(f MATCHES "\\.h$")
    get_filename_component(name ${f} NAME)
    get_filename_component(dir ${f} DIRECTORY)
    if(DEFINED home_${name} AND NOT home_${name} STREQUAL dir)
      message(FATAL_ERROR "layers: header ${name} exists in both ${home_${name}} and ${dir}: names must be unique")
    endif()
    set(home_${name} ${dir})
  endif()
endforeach()

function(layer_of path out)
  get_filename_component(dir ${path} DIRECTORY)
  if(path STREQUAL "hal/hal.h")
    set(dir hal)
  endif()
  if(NOT DEFINED layer_${dir})
    message(FATAL_ERROR "layers: ${path} is in ${dir}, which has no layer (add it to check_layers.cmake)")
  endif()
  set(${out} ${layer_${dir}} PARENT_SCOPE)
endfunction()

set(bad "")
set(edges "")
foreach(f ${sources})
  get_filename_component(from_dir ${f} DIRECTORY)
  list(FIND PROGRAMS ${f} is_program)
  if(is_program GREATER -1)
    set(from_layer 6)
    set(from_node "${from_dir} (programs)")
  else()
    layer_of(${f} from_layer)
    set(from_node ${from_dir})
  endif()
  file(STRINGS ${SOURCE_DIR}/${f} includes REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(line ${includes})
    string(REGEX REPLACE ".*#[ \t]*include[ \t]*\"([^\"]+)\".*" "\\1" inc "${line}")
    get_filename_component(name ${inc} NAME)
    if(NOT DEFINED home_${name})
      continue() # a Debian library's header (stb, OpenEXR) or a generated one
    endif()
    set(to_dir ${home_${name}})
    if(to_dir STREQUAL from_dir)
      continue()
    endif()
    layer_of(${to_dir}/${name} to_layer)
    set(to_node ${to_dir})
    if("${to_dir}/${name}" STREQUAL "hal/hal.h")
      set(to_node "hal/hal.h")
    endif()
    list(APPEND edges "${from_node} -> ${to_node}")
    if(to_layer GREATER from_layer OR (to_layer EQUAL from_layer AND from_layer EQUAL 2))
      list(APPEND bad "${f} includes ${to_dir}/${name} (layer ${from_layer} -> ${to_layer})")
    endif()
  endforeach()
endforeach()

layer_report_edges(${edges})
layer_fail_on_bad("layers: includes that point up or sideways" ${bad})
message(STATUS "layers: no include points up")
