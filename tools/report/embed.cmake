# Writes OUT: a C++ file defining vigil::cli::kReportHtml, kReportJs and kReportCss from the
# files HTML, JS and CSS (raw string literals; the files must not contain the delimiter).
foreach(var HTML JS CSS)
  file(READ "${${var}}" content)
  string(FIND "${content}" ")VIGIL_ASSET\"" bad)
  if(NOT bad EQUAL -1)
    message(FATAL_ERROR "${${var}} contains the raw-string delimiter )VIGIL_ASSET\"")
  endif()
  set(${var}_TEXT "${content}")
endforeach()
file(WRITE "${OUT}.tmp" "// Generated from tools/report/ by tools/report/embed.cmake; do not edit.\n"
  "namespace vigil::cli {\n"
  "extern const char kReportHtml[] = R\"VIGIL_ASSET(${HTML_TEXT})VIGIL_ASSET\";\n"
  "extern const char kReportJs[] = R\"VIGIL_ASSET(${JS_TEXT})VIGIL_ASSET\";\n"
  "extern const char kReportCss[] = R\"VIGIL_ASSET(${CSS_TEXT})VIGIL_ASSET\";\n"
  "}  // namespace vigil::cli\n")
file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
