/* SPDX-License-Identifier: MIT */
/*
 * dr_decode ASSEMBLY FILE: the image in FILE as `drcli decode` prints it,
 * written against the public API only (the field table through
 * dr_field_count/dr_field_at, paths, values as text).
 * dr_decode --bounds: the client's bounds as this program and the library
 * were compiled (the CMake package carries them to both).
 */
#include <stdio.h>
#include <string.h>

#include "drgate/client.h"
#include "drgate/text.h"

static void line(const uint8_t *img, size_t len, const dr_field_t *f, int elem)
{
    dr_ref_t ref = {f, (int16_t)elem};
    char path[64], text[64];
    dr_value_t v;
    if (dr_ref_path(ref, path, sizeof path) != DR_OK || dr_field_get(img, len, ref, &v) != DR_OK ||
        dr_text_format(ref, &v, DR_TEXT_UNIT, text, sizeof text) != DR_OK)
        strcpy(text, "?");
    printf("%s = %s\n", path, text);
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--bounds") == 0) {
        printf("DR_CLIENT_MAX_CONNS=%d storage=%zu library=%zu\n", DR_CLIENT_MAX_CONNS,
               sizeof(dr_client_storage_t), dr_client_size());
        return 0;
    }
    dr_asm_t a;
    static uint8_t img[DR_ASM_MAX_SIZE + 1];
    FILE *in = argc == 3 ? fopen(argv[2], "rb") : NULL;
    if (in == NULL || dr_asm_lookup(argv[1], &a) != DR_OK) {
        fprintf(stderr, "usage: dr_decode ASSEMBLY FILE | --bounds\n");
        return 2;
    }
    size_t len = fread(img, 1, sizeof img, in);
    fclose(in);
    if (len != dr_asm_info(a)->size) {
        fprintf(stderr, "dr_decode: %zu bytes, %s has %u\n", len, argv[1], dr_asm_info(a)->size);
        return 2;
    }
    for (uint16_t i = 0; i < dr_field_count(); i++) {
        const dr_field_t *f = dr_field_at(i);
        if (f->assembly != (uint8_t)a)
            continue;
        if (f->kind == DR_KIND_BITS)
            line(img, len, f, -1); /* the whole mask first */
        for (int e = 0; e < (f->indexed ? f->count : 1); e++)
            line(img, len, f, e);
    }
    return 0;
}
