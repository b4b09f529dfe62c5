#include "scene/gltf_import.h"
