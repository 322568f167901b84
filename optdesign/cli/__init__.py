"""The command line: ``optdesign COMMAND`` with one thin module per command (:mod:`.main` is the
registry).  May import every other subpackage; nothing imports cli."""
