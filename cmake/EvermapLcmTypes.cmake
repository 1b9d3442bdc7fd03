# evermap_lcmtypes(TARGET <name> FILES <.lcm ...>)
# Generates C++ headers (an INTERFACE library <name>) and, when Java is on, <name>.jar.
function(evermap_lcmtypes)
  cmake_parse_arguments(A "" "TARGET" "FILES" ${ARGN})
  set(cpp_dir ${CMAKE_CURRENT_BINARY_DIR}/cpp)
  set(java_dir ${CMAKE_CURRENT_BINARY_DIR}/java)
  set(headers)
  set(java_sources)
  foreach(f ${A_FILES})
    get_filename_component(abs ${f} ABSOLUTE)
    get_filename_component(stem ${f} NAME_WE)          # evermap_image_t
    string(REGEX REPLACE "^evermap_" "" type ${stem})  # image_t
    list(APPEND headers ${cpp_dir}/evermap/${type}.hpp)
    list(APPEND java_sources ${java_dir}/evermap/${type}.java)
    list(APPEND abs_files ${abs})
  endforeach()
  add_custom_command(
    OUTPUT ${headers}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${cpp_dir}
    COMMAND ${LCM_GEN} --cpp --cpp-hpath ${cpp_dir} ${abs_files}
    DEPENDS ${abs_files}
    COMMENT "lcm-gen --cpp: ${A_TARGET}")
  add_custom_target(${A_TARGET}_gen DEPENDS ${headers})
  add_library(${A_TARGET} INTERFACE)
  add_dependencies(${A_TARGET} ${A_TARGET}_gen)
  target_include_directories(${A_TARGET} INTERFACE ${cpp_dir})
  target_link_libraries(${A_TARGET} INTERFACE evermap_lcm)

  if(EVERMAP_BUILD_JAVA)
    set(classes_dir ${CMAKE_CURRENT_BINARY_DIR}/classes)
    set(jar ${CMAKE_BINARY_DIR}/share/java/${A_TARGET}.jar)
    add_custom_command(
      OUTPUT ${jar}
      COMMAND ${CMAKE_COMMAND} -E rm -rf ${java_dir} ${classes_dir}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${java_dir} ${classes_dir} ${CMAKE_BINARY_DIR}/share/java
      COMMAND ${LCM_GEN} --java --jpath ${java_dir} ${abs_files}
      COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -cp ${LCM_JAR} -d ${classes_dir} ${java_sources}
      COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${classes_dir} .
      DEPENDS ${abs_files}
      COMMENT "lcm-gen --java + javac: ${A_TARGET}.jar")
    add_custom_target(${A_TARGET}_jar ALL DEPENDS ${jar})
  endif()
endfunction()
