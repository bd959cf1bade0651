// A unit's page: the note saying its spec sheet is being rendered goes once the sheet's
// frame has loaded (station/web/pages.py's unit_body). The frame is sandboxed: nothing of
// it is read, only its load event.
"use strict";
(function () {
  const frame = document.querySelector("iframe.sheet");
  const note = document.getElementById("sheet-rendering");
  if (!frame || !note) return;
  frame.addEventListener("load", () => {
    note.remove();
    document.body.dataset.sheetLoaded = "1";
  });
})();
