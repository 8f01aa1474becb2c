// Progressive enhancement: everything works without this file. With it, the progress page is
// never reloaded: progress is announced in its live region, and when the job is done the results
// are swapped in, announced, and focus moves to the results heading. The 3D view loads on demand.
(function () {
  "use strict";
  const base = document.body.dataset.base || "";
  // Focus goes to what the page has to say first: its errors, or the files an upload refused.
  const first = document.getElementById("error-summary") || document.querySelector("[data-focus-on-load]");
  if (first) first.focus();
  loadViewer();
  keepAlive();
  const job = document.getElementById("job");
  if (!job || job.dataset.state !== "running") return;
  const status = document.getElementById("job-status");
  const check = document.getElementById("check-progress");
  const note = document.getElementById("progress-note");
  if (check) check.hidden = true;  // the page updates itself now
  if (note) note.textContent = "This page updates by itself; you can stay here.";

  // A job's files stay while its page is open: the page asks for the job's status now and then.
  function keepAlive() {
    const id = document.body.dataset.jobId, every = Number(document.body.dataset.keepaliveMs);
    if (!id || !every) return;
    setInterval(function () {
      fetch(base + "/jobs/" + id + "/status", { cache: "no-store" }).catch(function () { /* the server is gone */ });
    }, every);
  }

  function loadViewer() {
    if (document.querySelector("model-viewer") && !customElements.get("model-viewer")) {
      import(base + "/static/vendor/model-viewer.min.js").catch(function () { /* the pictures remain */ });
    }
  }

  async function showResults(message) {
    const response = await fetch(base + "/jobs/" + job.dataset.job, { cache: "no-store" });
    const page = new DOMParser().parseFromString(await response.text(), "text/html");
    const body = page.getElementById("job-body");
    if (!body) { window.location.reload(); return; }
    document.getElementById("job-body").replaceWith(document.adoptNode(body));
    job.dataset.state = "done";
    document.title = page.title;
    document.querySelectorAll("nav.steps").forEach(function (nav, i) {
      const fresh = page.querySelectorAll("nav.steps")[i];
      if (fresh) nav.replaceWith(document.adoptNode(fresh));
    });
    const heading = document.getElementById("page-title");
    if (heading) heading.focus();
    // After the focus move, so the heading is read first and the news is not cut off.
    setTimeout(function () { status.textContent = message; }, 250);
    loadViewer();
  }

  async function poll() {
    try {
      const response = await fetch(base + "/jobs/" + job.dataset.job + "/status", { cache: "no-store" });
      const data = await response.json();
      const progress = document.getElementById("progress");
      if (progress) { progress.max = data.total; progress.value = data.done; progress.textContent = data.done + " of " + data.total; }
      if (data.state === "running") {
        if (status.textContent !== data.message) status.textContent = data.message;
        setTimeout(poll, 1000);
      } else if (data.state === "done") {
        await showResults(data.message);
      } else {
        status.textContent = "This job has ended; start again from the first page.";
      }
    } catch (error) {
      status.textContent = "Lost contact with the TAMP-OS server; use Check progress to try again.";
      if (check) check.hidden = false;
    }
  }
  setTimeout(poll, 1000);
})();
