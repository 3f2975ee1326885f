/* A firmware header, so the fixture has the bottom layer. */
