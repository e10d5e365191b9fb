# Installs hapticcal from BUILD_DIR into a scratch prefix and builds the
# consumer example with find_package(hapticcal), then runs it.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the consumer failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the consumer failed: ${rc}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/consumer ${WORK_DIR}/prefix/share/hapticcal/devices/baser-7dof.yaml
                RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message("${out}")
if(rc OR NOT out MATCHES "tool point at home: ")
  message(FATAL_ERROR "the consumer did not run: ${rc}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/core_consumer RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message("${out}")
if(rc OR NOT out MATCHES "core: tool point at home: 0.400")
  message(FATAL_ERROR "the core consumer did not run: ${rc}")
endif()

# The pkg-config files: the README's link lines (docs/runtime.md) build the C runtime's
# realtime example and the C++ consumer against the installed tree.
set(ENV{PKG_CONFIG_PATH} ${WORK_DIR}/prefix/lib/pkgconfig)
function(pkg_flags package out)
  execute_process(COMMAND pkg-config --cflags --libs ${package} RESULT_VARIABLE rc
                  OUTPUT_VARIABLE flags ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc)
    message(FATAL_ERROR "pkg-config ${package} failed: ${err}")
  endif()
  separate_arguments(flags UNIX_COMMAND "${flags}")
  set(${out} ${flags} PARENT_SCOPE)
endfunction()
pkg_flags(hapticcal-runtime runtime_flags)
execute_process(COMMAND cc -std=c99 ${SOURCE_DIR}/examples/realtime/realtime_controller.c
                        -o ${WORK_DIR}/realtime_controller ${runtime_flags}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "cc with pkg-config hapticcal-runtime failed: ${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/realtime_controller
                        ${WORK_DIR}/prefix/share/hapticcal/devices/baser-7dof.yaml --seconds 0.3
                RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message("${out}")
if(rc OR NOT out MATCHES "missed deadlines: [0-9]+ of 300")
  message(FATAL_ERROR "the realtime example built by pkg-config did not run: ${rc}")
endif()
pkg_flags(hapticcal library_flags)
execute_process(COMMAND c++ -std=c++20 ${SOURCE_DIR}/examples/consumer/main.cpp
                        -o ${WORK_DIR}/pkg_consumer ${library_flags}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc)
  message(FATAL_ERROR "c++ with pkg-config hapticcal failed: ${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/pkg_consumer ${WORK_DIR}/prefix/share/hapticcal/devices/baser-7dof.yaml
                RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(rc OR NOT out MATCHES "tool point at home: ")
  message(FATAL_ERROR "the consumer built by pkg-config did not run: ${rc}")
endif()

# The Python module, when built: installed where Debian's python3 looks
# (PREFIX/lib/python3.X/dist-packages), and that copy imported by /usr/bin/python3.
file(GLOB built ${BUILD_DIR}/python/hapticcal*.so)
if(built)
  file(GLOB installed ${WORK_DIR}/prefix/lib/python3*/dist-packages/hapticcal*.so)
  if(NOT installed)
    message(FATAL_ERROR "the Python module is not in ${WORK_DIR}/prefix/lib/python3*/dist-packages")
  endif()
  get_filename_component(site ${installed} DIRECTORY)
  set(ENV{PYTHONPATH} ${site})
  execute_process(
    COMMAND /usr/bin/python3 -c
            "import hapticcal, sys; m = hapticcal.load_model(sys.argv[1]); print(hapticcal.__file__, m.dof, m.forward([0.0] * m.dof)[0:3, 3])"
            ${WORK_DIR}/prefix/share/hapticcal/devices/baser-7dof.yaml
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}")
  if(rc OR NOT out MATCHES "^${site}/hapticcal[^ ]*\\.so 7 ")
    message(FATAL_ERROR "the installed Python module was not the one imported: ${rc} ${err}")
  endif()

  # A calibration's device.yaml (the model in the device's own frame) in the
  # controller: the realtime example built above prints the tool point at its
  # home readings, the installed module computes it from the same file.
  execute_process(
    COMMAND ${WORK_DIR}/prefix/bin/hapticcal calibrate
            --model ${SOURCE_DIR}/examples/meca500/meca500.yaml
            --log ${SOURCE_DIR}/examples/meca500/cal-norm_dist_data_0deg_160cube.csv
            --tool-point 0,0,0.07 --out ${WORK_DIR}/calibrated
    RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(rc)
    message(FATAL_ERROR "the installed hapticcal did not calibrate: ${rc} ${err}")
  endif()
  execute_process(COMMAND ${WORK_DIR}/realtime_controller ${WORK_DIR}/calibrated/device.yaml
                          --seconds 0.6
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  string(REGEX MATCH "tool point at the home readings \\(0.1 each\\): ([-0-9.]+) ([-0-9.]+) ([-0-9.]+) m"
         line "${out}")
  if(rc OR NOT line)
    message(FATAL_ERROR "the realtime example on device.yaml: ${rc} ${out}")
  endif()
  set(printed ${CMAKE_MATCH_1} ${CMAKE_MATCH_2} ${CMAKE_MATCH_3})
  execute_process(
    COMMAND /usr/bin/python3 -c
            "import hapticcal, sys; m = hapticcal.load_model(sys.argv[1]); p = m.forward([0.1] * m.dof)[0:3, 3]; c = [float(v) for v in sys.argv[2:5]]; d = max(abs(a - b) for a, b in zip(p, c)); print(f'device.yaml: C runtime {c}, Python {list(p)}, largest difference {d:.3g} m'); sys.exit(int(d > 1e-9))"
            ${WORK_DIR}/calibrated/device.yaml ${printed}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}")
  if(rc)
    message(FATAL_ERROR "the C runtime and the module differ on device.yaml: ${rc} ${err}")
  endif()
endif()
