// palpate/palpate.h — everything in palpate's public API.
#pragma once

#include <palpate/core.h>
#include <palpate/device.h>
#include <palpate/mesh.h>
#include <palpate/run.h>
#include <palpate/scene.h>
#include <palpate/tissue.h>
