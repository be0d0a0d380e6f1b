# Runs at install time (install(SCRIPT) from CMakeLists.txt), so that what it
# writes follows the prefix of *this* install, not the configure prefix:
# `cmake --install build --prefix /opt/cobridge` gets
# ExecStart=/opt/cobridge/bin/cobridged, the Debian package (prefix /usr)
# gets /usr/bin/cobridged and /etc/cobridge.
#   - <prefix>/lib/systemd/system/cobridged.service from the template;
#   - <sysconfdir>/cobridge/cobridge.toml (the shipped default), unless one
#     is there already: an install never overwrites an operator's file.
# <sysconfdir> is /etc for the prefix /usr, else <prefix>/etc (GNUInstallDirs).
# In: COBRIDGE_SOURCE_DIR, COBRIDGE_BINARY_DIR, COBRIDGE_BINDIR,
#     COBRIDGE_DOCDIR, COBRIDGE_SYSTEMD_DIR (relative to the prefix).
set(prefix "${CMAKE_INSTALL_PREFIX}")
if(prefix STREQUAL "/usr")
  set(sysconfdir "/etc")
else()
  set(sysconfdir "${prefix}/etc")
endif()

file(READ "${COBRIDGE_SOURCE_DIR}/systemd/cobridged.service.in" unit)
string(REPLACE "@COBRIDGE_UNIT_BINDIR@" "${prefix}/${COBRIDGE_BINDIR}" unit "${unit}")
string(REPLACE "@COBRIDGE_UNIT_SYSCONFDIR@" "${sysconfdir}" unit "${unit}")
string(REPLACE "@COBRIDGE_UNIT_DOCDIR@" "${prefix}/${COBRIDGE_DOCDIR}" unit "${unit}")
if(unit MATCHES "@COBRIDGE_[A-Z_]+@")
  message(FATAL_ERROR "cobridged.service.in: placeholder left: ${CMAKE_MATCH_0}")
endif()
set(staged "${COBRIDGE_BINARY_DIR}/install-staging")
file(MAKE_DIRECTORY "${staged}")
file(WRITE "${staged}/cobridged.service" "${unit}")
file(INSTALL DESTINATION "${prefix}/${COBRIDGE_SYSTEMD_DIR}" TYPE FILE FILES "${staged}/cobridged.service")

if(EXISTS "$ENV{DESTDIR}${sysconfdir}/cobridge/cobridge.toml")
  message(STATUS "Keeping: $ENV{DESTDIR}${sysconfdir}/cobridge/cobridge.toml")
else()
  configure_file("${COBRIDGE_SOURCE_DIR}/config/cobridge-default.toml" "${staged}/cobridge.toml" COPYONLY)
  file(INSTALL DESTINATION "${sysconfdir}/cobridge" TYPE FILE FILES "${staged}/cobridge.toml")
endif()
