"""dsmv's built-in plugins, registered by entry point exactly like third-party ones."""
