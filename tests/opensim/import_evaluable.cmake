# `import` reports success only for a model the engine can evaluate (issue 25 item 6): an
# import with no movable joint between clamp and endpoint, and one whose chain carries no
# muscle path, exit 1 naming why, and write no file.
get_filename_component(dir ${OUT} DIRECTORY)
file(MAKE_DIRECTORY ${dir})
file(REMOVE ${OUT})
execute_process(COMMAND ${CLI} import ${OSIM} -o ${OUT} --clamp toes --endpoint claw
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 1 OR NOT err MATCHES "cannot be evaluated: .*has no movable joint; nothing was written")
  message(FATAL_ERROR "no movable joint: exit ${rc}, stdout: ${out} stderr: ${err}")
endif()
if(EXISTS ${OUT})
  message(FATAL_ERROR "no movable joint: ${OUT} was written")
endif()
# The same model without its ForceSet: no muscle on any chain.
file(READ ${OSIM} xml)
string(REGEX REPLACE "<ForceSet name=\"forceset\">.*</ForceSet>" "" xml "${xml}")
file(WRITE ${dir}/no_muscles.osim "${xml}")
execute_process(COMMAND ${CLI} import ${dir}/no_muscles.osim -o ${OUT} --clamp pelvis --endpoint foot
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 1 OR NOT err MATCHES "the chain from 'pelvis' to 'foot' carries no muscle path")
  message(FATAL_ERROR "no muscle: exit ${rc}, stdout: ${out} stderr: ${err}")
endif()
if(EXISTS ${OUT})
  message(FATAL_ERROR "no muscle: ${OUT} was written")
endif()
