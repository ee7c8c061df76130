/* Model descriptors: what IDENTIFY reports (docs/device-protocol.md §3) and what the device
 * accepts. Const data only; a device state points at one of these (model vs data split). */
#include <string.h>

#include "viestac_fw.h"

/* FingerTac: two LRAs at their 235 Hz resonance; vibration only (thesis §3.1). */
const vt_model vt_model_fingertac = {
    "fingertac", 1, 0, 0, 2, VT_CAP_PULSE | VT_CAP_CONTINUOUS | VT_CAP_TEXTURE, 235
};

/* FerroVibe: one magnet tilted by two solenoids; 235 Hz is its default re-tilting rate. */
const vt_model vt_model_ferrovibe = {
    "ferrovibe", 1, 0, 0, 1, VT_CAP_PULSE | VT_CAP_CONTINUOUS | VT_CAP_TEXTURE | VT_CAP_TILT, 235
};

/* ViESTac devkit, the reference firmware for new devices: one LRA (235 Hz carrier), a Peltier element
 * and a friction display on one fingertip, so every layer but tilt has an actuator. */
const vt_model vt_model_devkit = {
    "devkit", 1, 0, 0, 1,
    VT_CAP_PULSE | VT_CAP_CONTINUOUS | VT_CAP_TEXTURE | VT_CAP_TEMPERATURE | VT_CAP_FRICTION, 235
};

const vt_model *vt_model_by_name(const char *name)
{
    static const vt_model *const models[] = { &vt_model_fingertac, &vt_model_ferrovibe, &vt_model_devkit };
    for (size_t i = 0; name && i < sizeof models / sizeof models[0]; i++)
        if (strcmp(models[i]->name, name) == 0)
            return models[i];
    return NULL;
}
