/* A host header, for the planted fault. */
