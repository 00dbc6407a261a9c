/* th on the host: output to stdout. Test programs define th_main(). */
#include <stdio.h>
#include "th.h"

void th_write(const char *s) { fputs(s, stdout); fflush(stdout); }

int main(int argc, char **argv) { return th_main(argc, argv) ? 1 : 0; }
