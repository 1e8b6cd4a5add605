# An import that fails (an endpoint that does not exist, then a malformed file) must exit 1,
# name the file, and leave an existing output file byte for byte as it was.
file(WRITE ${OUT} "previous content\n")
execute_process(COMMAND ${CLI} import ${OSIM} -o ${OUT} --clamp pelvis --endpoint paw
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 1 OR NOT err MATCHES "hindlimb.osim: --endpoint body 'paw' does not exist")
  message(FATAL_ERROR "exit ${rc}, stderr: ${err}")
endif()
get_filename_component(dir ${OUT} DIRECTORY)
file(WRITE ${dir}/broken.osim "<OpenSimDocument Version=\"40000\">\n<Model name=\"x\">\n</OpenSimDocument>\n")
execute_process(COMMAND ${CLI} import ${dir}/broken.osim -o ${OUT} --clamp a --endpoint b
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 1 OR NOT err MATCHES "broken.osim:[0-9]+: malformed XML")
  message(FATAL_ERROR "exit ${rc}, stderr: ${err}")
endif()
file(READ ${OUT} content)
if(NOT content STREQUAL "previous content\n")
  message(FATAL_ERROR "the existing output file was changed: ${content}")
endif()
file(GLOB leftovers ${dir}/kept.urdf?*)
if(leftovers)
  message(FATAL_ERROR "temporary files left: ${leftovers}")
endif()
