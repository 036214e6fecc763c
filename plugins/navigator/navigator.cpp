// The navigator controller plugin (plugins/navigator/navigator.h).
#include "plugins/navigator/navigator.h"
#include "plugins/plugin_export.h"

VIGIL_PLUGIN(navigator, vigil::plugins::Navigator)
