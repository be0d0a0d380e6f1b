/* A valid shared object that does not export cobridge_plugin_create (the
 * name is misspelt), as a library built without the entry point would be. */
#include <cobridge/plugin.h>

COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_creat(void);

int cobridge_plugin_creat(void) { return 0; }
