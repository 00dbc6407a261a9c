/*
 * main.c — entry point of the host tool: `plotkin <command> [options]`.
 * Commands are listed once, in the table below.
 */
#include <stdio.h>
#include <string.h>
#include "commands.h"

struct pk_command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
};

static const struct pk_command commands[] = {
    { "refine", cmd_refine, "smooth a polyline read from stdin (subdivision kernel)" },
    { "sim", cmd_sim, "run a G-code or polyline file through the firmware on a simulated machine" },
    { "serve", cmd_serve, "run the simulated machine in real time, speaking Grbl 1.1 on a pty" },
    { "avrsim", cmd_avrsim, "run a board's firmware image on an emulated AVR (simavr)" },
};

static void usage(FILE *f)
{
    fputs("usage: plotkin <command> [options]\n\ncommands:\n", f);
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].summary);
    fputs("\n`plotkin <command> --help` describes a command's options.\n", f);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "plotkin: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
