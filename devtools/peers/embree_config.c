/* Appends $RAYTRACE_EMBREE_CONFIG to the configuration string Mitsuba 3 opens its Embree device with.
 *
 * Embree chooses its instruction set from CPUID; a device's configuration (`isa=avx2`, Embree's API manual,
 * rtcNewDevice) is the only way to narrow it, and Mitsuba opens its device with a fixed one
 * ("threads=N,user_threads=N"). mitsuba_isa.py builds this file into a shared library and preloads it,
 * so the symbol below stands in front of the one in Mitsuba's libembree3.so, which it then calls. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *(*NewDevice)(const char *config);

void *_ZN7mitsuba12rtcNewDeviceEPKc(const char *config) {
    /* RTLD_NEXT misses it: Python opens Mitsuba's modules, and so their libembree3.so, with RTLD_LOCAL. */
    void *embree = dlopen("libembree3.so", RTLD_NOW | RTLD_NOLOAD);
    NewDevice next = embree ? (NewDevice)dlsym(embree, "_ZN7mitsuba12rtcNewDeviceEPKc") : NULL;
    if (!next) {
        fprintf(stderr, "embree_config: Mitsuba's libembree3.so is not loaded\n");
        abort();
    }
    const char *extra = getenv("RAYTRACE_EMBREE_CONFIG");
    char joined[1024];
    snprintf(joined, sizeof joined, "%s%s%s", config ? config : "", (config && *config && extra) ? "," : "",
             extra ? extra : "");
    return next(joined);
}
