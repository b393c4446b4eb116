# cmake -DECMOR=exe -DPLUGIN=lib -DCONFIG=yaml -DOUTPUT=dir -P run_reduce.cmake
# Runs `ecmor reduce` on one configuration with the plugin and fails unless the driver exits 0
# (tolerance met) and its summary.json says the run converged.
foreach(var ECMOR PLUGIN CONFIG OUTPUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_reduce.cmake: -D${var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE "${OUTPUT}")
execute_process(
  COMMAND "${ECMOR}" reduce "${CONFIG}" --plugin "${PLUGIN}" -o "${OUTPUT}" --no-plot
  RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "ecmor reduce ${CONFIG} exited with ${status} (0 = tolerance met)")
endif()
if(NOT EXISTS "${OUTPUT}/summary.json")
  message(FATAL_ERROR "no summary.json in ${OUTPUT}")
endif()
file(READ "${OUTPUT}/summary.json" summary)
string(JSON termination GET "${summary}" termination)
string(JSON target_met GET "${summary}" target_met)
string(JSON order GET "${summary}" final_order)
string(JSON verified GET "${summary}" verified_band_error)
if(NOT termination STREQUAL "converged" OR NOT target_met)
  message(FATAL_ERROR "summary.json: termination '${termination}', target_met ${target_met}; "
                      "expected 'converged', true")
endif()
message(STATUS "converged at order ${order}, verified band error ${verified}")
