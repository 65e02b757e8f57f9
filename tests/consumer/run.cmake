# The install-and-consume test (ctest -R Package): installs the built tree into a fresh prefix,
# then configures, builds and runs this folder's project against it through find_package, with
# the tree's generator, compiler and build type. `cmake --install` builds nothing: it reuses the
# tree as built. Called as cmake -DBUILD_DIR= -DCONFIG= -DWORK_DIR= -DGENERATOR= -DCXX_COMPILER=
# -DSOURCE_DIR= -P run.cmake.
set(prefix ${WORK_DIR}/prefix)
set(consumer_build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR})
if(CONFIG)
  set(config_option --config ${CONFIG})
  set(ctest_config_option -C ${CONFIG})
endif()

execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} ${config_option}
  OUTPUT_QUIET COMMAND_ERROR_IS_FATAL ANY)

# The package must not point back into the source or build tree: it has to work once they are gone.
file(GLOB_RECURSE package_files ${prefix}/*.cmake)
foreach(file IN LISTS package_files)
  file(READ ${file} text)
  foreach(tree IN ITEMS ${SOURCE_DIR} ${BUILD_DIR})
    string(FIND "${text}" "${tree}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "${file} names ${tree}: the installed package depends on that tree")
    endif()
  endforeach()
endforeach()

execute_process(COMMAND ${CMAKE_COMMAND} -S ${CMAKE_CURRENT_LIST_DIR} -B ${consumer_build} -G ${GENERATOR}
  -DCMAKE_BUILD_TYPE=${CONFIG} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix}
  COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${CMAKE_COMMAND} --build ${consumer_build} ${config_option} COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${CMAKE_CTEST_COMMAND} --test-dir ${consumer_build} --output-on-failure ${ctest_config_option}
  COMMAND_ERROR_IS_FATAL ANY)
