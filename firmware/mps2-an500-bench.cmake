# bench_target's half on the board: the kernel and row path counted in instructions under QEMU.
add_executable(wdr_bench_mps2 ${PROJECT_SOURCE_DIR}/tests/bench/bench_target_arm/main_bench.c)
set_target_properties(wdr_bench_mps2 PROPERTIES SUFFIX ".elf")
target_include_directories(wdr_bench_mps2 PRIVATE ${WDR_MPS2_DIR})
target_link_libraries(wdr_bench_mps2 PRIVATE wdr_fw)
target_link_options(wdr_bench_mps2 PRIVATE -T${WDR_MPS2_DIR}/mps2-an500.ld)
