/* SPDX-License-Identifier: MIT */
/*
 * The `eds` key of [robot NAME]: the robot's EDS read with the reader
 * drcli eds uses (common/eds.c) into the plan it gives
 * (common/eds_plan.c). config_robot.c takes the plan as the robot's
 * defaults; here the file is found, read and parsed, and what goes wrong
 * is said with the EDS's FILE:LINE at the config line of the key.
 */
#include "core/config_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EDS_FILE_MAX (1u << 20) /* as drcli eds: larger is no EDS */

/* path as written, relative to the configuration file's folder. */
static void eds_path(const gw_cfg_ctx_t *c, const char *path, char *out, size_t size)
{
    const char *slash = c->path != NULL ? strrchr(c->path, '/') : NULL;
    if (path[0] == '/' || slash == NULL)
        snprintf(out, size, "%s", path);
    else
        snprintf(out, size, "%.*s/%s", (int)(slash - c->path), c->path, path);
}

/* The file's text into a buffer of EDS_FILE_MAX bytes; false after the
 * message. */
static bool eds_read(gw_cfg_ctx_t *c, unsigned line, const char *name, const char *file,
                     char *buf, size_t *len)
{
    FILE *fp = fopen(file, "rb");
    if (fp == NULL) {
        gw_cfg_fail(c, line, "robot '%s': eds %s: cannot open: %s", name, file,
                    strerror(errno));
        return false;
    }
    size_t n = fread(buf, 1, EDS_FILE_MAX, fp);
    bool ok = !ferror(fp), big = n == EDS_FILE_MAX && fgetc(fp) != EOF;
    (void)fclose(fp);
    if (!ok)
        gw_cfg_fail(c, line, "robot '%s': eds %s: cannot read", name, file);
    else if (big)
        gw_cfg_fail(c, line, "robot '%s': eds %s: larger than %u bytes: not an EDS", name,
                    file, EDS_FILE_MAX);
    *len = n;
    return ok && !big;
}

bool gw_cfg_eds_load(gw_cfg_ctx_t *c, unsigned line, const char *name, const char *path,
                     eds_plan_t *plan, char *file, size_t file_size)
{
    eds_path(c, path, file, file_size);
    char *text = malloc(EDS_FILE_MAX);
    eds_t *eds = malloc(sizeof *eds);
    bool ok = text != NULL && eds != NULL;
    size_t len = 0;
    if (!ok)
        gw_cfg_fail(c, line, "robot '%s': eds %s: out of memory", name, file);
    else
        ok = eds_read(c, line, name, file, text, &len);
    if (ok) {
        char err[160];
        unsigned at = 0;
        ok = eds_parse(text, len, eds, &at, err, sizeof err);
        if (!ok)
            gw_cfg_fail(c, line, "robot '%s': eds %s:%u: %s", name, file, at, err);
    }
    if (ok)
        eds_plan(eds, plan);
    free(text);
    free(eds);
    return ok;
}
