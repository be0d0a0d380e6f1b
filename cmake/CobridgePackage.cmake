# The Debian package: `cpack -G DEB` in a build tree (scripts/package makes a
# distribution build and calls it) -> cobridge_<version>_<arch>.deb.
# Depends are computed by dpkg-shlibdeps from the binaries and plugins (the
# MQTT plugin brings libmosquitto1 and libprotobuf-c1 that way); the
# maintainer scripts and conffiles are packaging/deb/.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME cobridge)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "cobridge")
set(CPACK_PACKAGE_CONTACT "cobridge maintainers <cobridge-maintainers@example.com>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "CANopen absolute-encoder gateway to Cyclone DDS and Modbus TCP")
# The extended description (CPack puts the summary above it and indents it).
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "cobridged finds the CANopen absolute encoders (Novotechnik rotary and
multiturn, ifm RM8/RM9) on SocketCAN buses, gives each its node-ID (LSS),
configures and supervises them, and publishes every position and speed on
Cyclone DDS and in Modbus TCP registers.

The package holds the daemon (a systemd Type=notify service running as
user cobridge), the command-line tool cobridge, the simulator cobridge-sim,
the DDS and Modbus output plugins, a Sparkplug B over MQTT output plugin
(first slice, docs/mqtt.md), the device descriptions (EDS), the
IDL of the DDS topics, and the plugin SDK (cobridge/plugin.h, cobridge/emcy.h,
libcobridge_sdk.a and its CMake package cobridge-sdk) for out-of-tree plugins.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # cobridge_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_RELEASE "")
set(CPACK_DEBIAN_PACKAGE_SECTION net)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# systemd-sysusers / systemd-tmpfiles in postinst; deb-systemd-helper and
# deb-systemd-invoke (init-system-helpers) for enabling and starting the unit.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd, init-system-helpers (>= 1.54~)")
# The web service dlopens libmicrohttpd (daemon/web/microhttpd.hpp), which
# dpkg-shlibdeps cannot see: the package that ships its SONAME is named here.
if(COBRIDGE_MICROHTTPD_SONAME)
  get_filename_component(_mhd_dir "${COBRIDGE_MICROHTTPD_FILE}" DIRECTORY)
  execute_process(COMMAND dpkg-query -S "${_mhd_dir}/${COBRIDGE_MICROHTTPD_SONAME}" OUTPUT_VARIABLE _mhd_owner
                  RESULT_VARIABLE _mhd_rc ERROR_QUIET)
  string(REGEX MATCH "^([^:]+)" _mhd_pkg "${_mhd_owner}")
  if(NOT _mhd_rc EQUAL 0 OR NOT _mhd_pkg)
    message(FATAL_ERROR "no Debian package owns ${_mhd_dir}/${COBRIDGE_MICROHTTPD_SONAME} (dpkg-query -S)")
  endif()
  string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", ${_mhd_pkg}")
endif()
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/deb/conffiles ${PROJECT_SOURCE_DIR}/packaging/deb/postinst
    ${PROJECT_SOURCE_DIR}/packaging/deb/prerm ${PROJECT_SOURCE_DIR}/packaging/deb/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
# DESTDIR staging: the unit and /etc/cobridge are written with the package's
# prefix (cmake/CobridgeInstallUnit.cmake), not with the staging directory.
set(CPACK_SET_DESTDIR ON)
set(CPACK_STRIP_FILES ON)
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/package)
include(CPack)
