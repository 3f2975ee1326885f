/* Where board and scene files are found by name: the folder named by an environment variable
 * (WDR_BOARDS_DIR, WDR_SCENES_DIR), else share/wdrcam/{boards,scenes} beside the running
 * program's folder (an install: PREFIX/bin and PREFIX/share; the build tree links its
 * build/share/wdrcam to the source folders). Nothing here knows where the source tree is, so
 * an installed program never reads it. */
#ifndef WDR_DATA_PATH_H
#define WDR_DATA_PATH_H
#include <stdio.h>

typedef enum wdr_data_kind {
    WDR_DATA_BOARDS, /* NAME/board.json */
    WDR_DATA_SCENES, /* NAME.json */
} wdr_data_kind;

/* The folder names of kind k are looked up in; "" when no folder is found (no variable set
 * and no share/wdrcam beside the program). */
void wdr_data_dir(wdr_data_kind k, char *out, int outlen);

/* A name's file; a path (it holds '/' or ends in .json) is kept as given. */
void wdr_data_path(wdr_data_kind k, const char *name, char *out, int outlen);

/* Whether text is a name to look up rather than a path. */
int wdr_data_is_name(const char *text);

/* The known names of kind k, sorted, separated by sep ("" when none). */
void wdr_data_names(wdr_data_kind k, const char *sep, char *out, int outlen);

/* "unknown board 'NAME' (known: a, b, c; in DIR, set by WDR_BOARDS_DIR)": the message for a name
 * that has no file. */
void wdr_data_unknown(wdr_data_kind k, const char *name, char *out, int outlen);

/* For shell completion: the names of "boards" or "scenes", one per line.
 * @return 1 when kind is one of them, else 0 (nothing printed) */
int wdr_data_print_names(FILE *f, const char *kind);

#endif
