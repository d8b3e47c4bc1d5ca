// palpate/palpate.h — everything in palpate's public API.
#pragma once

#include <palpate/anatomy.h>
#include <palpate/charged.h>
#include <palpate/checked_file.h>
#include <palpate/contact.h>
#include <palpate/core.h>
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/image.h>
#include <palpate/mesh.h>
#include <palpate/mesh_load.h>
#include <palpate/meshing.h>
#include <palpate/outcome.h>
#include <palpate/render.h>
#include <palpate/run.h>
#include <palpate/safety.h>
#include <palpate/scene.h>
#include <palpate/scene_def.h>
#include <palpate/simulation.h>
#include <palpate/snapshot_tissue.h>
#include <palpate/spring.h>
#include <palpate/surface.h>
#include <palpate/tissue_files.h>
#include <palpate/tissue.h>
