# test_docs_config_reference: docs/CONFIG.md must equal what edgefuse_config_reference prints from
# the parameter table (kParamDefs). -DGENERATOR=<program> -DDOC=<docs/CONFIG.md>
execute_process(COMMAND ${GENERATOR} OUTPUT_VARIABLE generated RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${GENERATOR} failed (${rc})")
endif()
if(NOT EXISTS ${DOC})
  set(committed "")
else()
  file(READ ${DOC} committed)
endif()
if(NOT generated STREQUAL committed)
  message(FATAL_ERROR "docs/CONFIG.md is stale: it differs from the parameter table. Regenerate it with\n"
    "  cmake --build build/host --target edgefuse_config_reference && "
    "build/host/tools/edgefuse_config_reference > docs/CONFIG.md")
endif()
message(STATUS "docs/CONFIG.md matches the parameter table")
