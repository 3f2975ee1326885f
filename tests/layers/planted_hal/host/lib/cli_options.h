/* Fixture: stands for host/lib/cli_options.h. */
