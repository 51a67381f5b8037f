# Installs the build into a scratch prefix, builds the consumer against it, and runs it.
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the consumer failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the consumer failed")
endif()
execute_process(COMMAND ${WORK_DIR}/build/consumer RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the consumer computed a wrong ||S||")
endif()
# The installed apps run from the installed prefix, and export a design for a controller.
file(MAKE_DIRECTORY ${WORK_DIR}/exported)
execute_process(COMMAND ${WORK_DIR}/prefix/bin/design-gains --robot pendubot --gamma 1.27 --sample-period 0.001
                        --encoder-counts 4096 --acceleration-bounds 200 --objective velocity-error --quiet
                        --export-header ${WORK_DIR}/exported/observer_gains.hpp
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the installed design-gains does not run")
endif()
# The controller links obsgain::runtime alone, and runs the exported observer.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${RUNTIME_SOURCE_DIR} -B ${WORK_DIR}/runtime-build
                        -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
                        -DEXPORTED_DIR=${WORK_DIR}/exported
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the runtime consumer failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/runtime-build RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the runtime consumer failed")
endif()
execute_process(COMMAND ${WORK_DIR}/runtime-build/controller RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the runtime consumer's observer did not converge on the exported design")
endif()
# What it pulls in: obsgain's runtime and the C++ runtime, no solver, no parser, no interval library.
execute_process(COMMAND ldd ${WORK_DIR}/runtime-build/controller OUTPUT_VARIABLE libraries RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT libraries MATCHES "libobsgain_runtime")
  message(FATAL_ERROR "ldd: ${libraries}")
endif()
foreach(forbidden nlopt ipopt urdfdom tinyxml console_bridge fmt boost obsgain_core obsgain_parsers obsgain_report)
  if(libraries MATCHES "${forbidden}")
    message(FATAL_ERROR "the runtime consumer links ${forbidden}:\n${libraries}")
  endif()
endforeach()
# The Python module, when it was built: imported from the installed prefix, with the installed libraries.
if(PYTHON)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${WORK_DIR}/prefix/${PYTHON_DIR}
                          ${PYTHON} -c "import obsgain; print(obsgain.__file__, obsgain.design_gains(obsgain.load_robot(), gamma=1.27).theta)"
                  OUTPUT_VARIABLE imported RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0 OR NOT imported MATCHES "^${WORK_DIR}/prefix/.* 33\\.03")
    message(FATAL_ERROR "the installed Python module does not run from the prefix: ${imported}")
  endif()
endif()
file(REMOVE_RECURSE ${WORK_DIR})
