#include "texture/image_decode.h"
