#include "scene/obj_import.h"
