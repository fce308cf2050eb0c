"""Tools on finished datasets: ``inspection`` (summary and plots), ``preview`` (annotated grids),
``replay`` (re-render a grasp sample from its USD description)."""
